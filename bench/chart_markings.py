#!/usr/bin/python3
"""Chart for bench_markings.csv (`photosite bench markings`): each dashed line's periods against
distance, measured through photosite's horizon (filled) and through the rig's nominal one
(hollow), with the standard pattern's period across where the line matches one. At the right
horizon and scale the periods lie flat on the standard."""
import csv, math, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def numbers(cell):
    """'1.9 (3.5) 2.0' -> [(1.9, True), (3.5, False), (2.0, True)]: a period in parentheses is irregular."""
    out = []
    for t in cell.split():
        regular = not t.startswith("(")
        out.append((float(t.strip("()")), regular))
    return out


rows = list(csv.DictReader(open(sys.argv[1])))
n = len(rows)
if n == 0:
    # A run that measured no line (a user's frame without dashed markings) still writes its chart,
    # so that no earlier run's chart stays beside this run's CSV.
    fig, ax = plt.subplots(figsize=(4.6, 3.6))
    ax.axis("off")
    ax.text(0.5, 0.5, "no dashed line measured\n(no line of 4 or more regular dashes;\nbench_markings.csv has no rows)",
            ha="center", va="center", fontsize=10)
    fig.suptitle("Dashed markings as rulers (photosite bench markings)", fontsize=9)
    fig.savefig(sys.argv[2], dpi=110)
    sys.exit(0)
cols = min(3, n)
fig, axes = plt.subplots(math.ceil(n / cols), cols, figsize=(4.6 * cols, 3.6 * math.ceil(n / cols)), squeeze=False)
for ax, r in zip(axes.flat, rows):
    D = [d for d, _ in numbers(r["periods_at_D_m"])]
    P = numbers(r["periods_m"])
    ax.scatter(D, [p for p, _ in P], color=["C0" if ok else "0.6" for _, ok in P], s=28,
               label=f"{'VP' if r['horizon_source'] == 'vanishing_point' else 'rig'} horizon, y {float(r['horizon_y']):.1f}")
    if r["rig_periods_m"]:
        Dr = [d for d, _ in numbers(r["rig_periods_at_D_m"])]
        Pr = numbers(r["rig_periods_m"])
        ax.scatter(Dr, [p for p, _ in Pr], facecolors="none", edgecolors=["C3" if ok else "0.6" for _, ok in Pr], s=28,
                   label=f"rig's nominal horizon, y {float(r['rig_horizon_y']):.1f}")
    if r["standard"]:
        std = float(r["standard_period_m"])
        ax.axhline(std, color="k", lw=0.8, ls="--", label=f"standard {std:g} m")
    ax.set_title(f"{r['frame']}, line {r['line']} (X {float(r['X_m']):.1f} m)\n"
                 f"{r['standard'].split(':')[0] if r['standard'] else 'no standard matched'}", fontsize=8)
    ax.set_xlabel("distance along the road (m)", fontsize=8)
    ax.set_ylabel("period (m)", fontsize=8)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
for ax in list(axes.flat)[n:]:
    ax.axis("off")
fig.suptitle("Dashed markings as rulers (photosite bench markings): grey = irregular period (a hidden or worn dash)",
             fontsize=9)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
