#!/usr/bin/python3
"""Chart for bench_noise.csv: time per frame against the worst KS distance at low means."""
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith("#"))][1:]
fig, ax = plt.subplots(figsize=(8, 5))
for i, r in enumerate(rows):
    if not r[-1]:
        continue
    t, ks = float(r[2]), max(float(r[-1]), 1e-4)
    ax.scatter(t, ks, s=60)
    ax.annotate(r[0].split(" (")[0] + f" [{r[1]} thr]", (t, ks), textcoords="offset points", xytext=(6, 4 - 12 * (i % 3)), fontsize=8)
ax.set_xscale("log"); ax.set_yscale("log")
ax.set_xlabel("ms per 2048x1024 frame (means 0.5..5000 e-)")
ax.set_ylabel("worst KS distance to Poisson at means 0.5..200 (400k draws)")
ax.axhline(1.36 / (400000 ** 0.5), color="grey", ls="--", lw=0.8)
ax.text(ax.get_xlim()[0] * 1.1, 1.36 / (400000 ** 0.5) * 1.1, "95% KS noise level of an exact sampler", fontsize=8, color="grey")
ax.set_title("Poisson samplers: speed against accuracy")
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
