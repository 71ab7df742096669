#!/usr/bin/python3
"""Chart for bench_png.csv (`photosite bench batch`): CPU ms to encode one 2048x1024 night preview
against MB per frame, for every filter / deflater / level / zlib strategy of our encoder
(core/png_codec.cpp) and for libpng and libspng; all lossless. The default is ringed."""
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

lines = open(sys.argv[1]).read().splitlines()
rows = list(csv.DictReader(l for l in lines if not l.startswith("#")))
notes = [l[2:] for l in lines if l.startswith("# ")]
groups = {}
for r in rows:
    key = r["deflate"] if r["encoder"] == "ours" else r["encoder"].split(" (")[0]
    groups.setdefault(key, []).append(r)
markers = {"none": "s", "sub": "o", "up": "^", "average": "v", "paeth": "D", "adaptive": "*"}
fig, ax = plt.subplots(figsize=(11, 6))
for i, (key, sel) in enumerate(sorted(groups.items())):
    for r in sel:
        t, mb = float(r["cpu_ms_per_frame"]), float(r["mb_per_frame"])
        ax.scatter(t, mb, color=f"C{i}", marker=markers.get(r["filter"], "o"), s=45)
        if r["default"] == "1":
            ax.scatter(t, mb, s=260, facecolors="none", edgecolors="k", linewidths=1.5)
            ax.annotate("default", (t, mb), textcoords="offset points", xytext=(8, -14), fontsize=9)
        if r["filter"] in ("sub", "paeth") and r["encoder"] == "ours":
            ax.annotate(f"{r['level']}", (t, mb), textcoords="offset points", xytext=(4, 4), fontsize=7, color=f"C{i}")
    ax.scatter([], [], color=f"C{i}", label=key)
for f, m in markers.items():
    ax.scatter([], [], color="grey", marker=m, label=f"filter {f}")
ax.set_xscale("log")
ax.set_xlabel("CPU ms to encode one frame (mean, log scale); small numbers: deflate level")
ax.set_ylabel("MB per frame")
ax.grid(alpha=0.3)
ax.legend(fontsize=8, ncol=2, loc="upper right")
fig.suptitle("Lossless PNG encoders and settings on the night previews (photosite bench batch)\n" +
             (notes[-1] if notes else ""), fontsize=9)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
