#!/usr/bin/python3
"""Chart for bench_exr.csv (`photosite bench exr`): ms to write against MB per frame for every
OpenEXR compression, all seven typed night layers and batch's default set; lossless codecs
filled, lossy hollow."""
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

lines = open(sys.argv[1]).read().splitlines()
rows = list(csv.DictReader(l for l in lines if not l.startswith("#")))
notes = [l[2:] for l in lines if l.startswith("# ")]
fig, axes = plt.subplots(1, 2, figsize=(12, 5.2))
for ax, layers in zip(axes, sorted({r["layers"] for r in rows}, key=len, reverse=True)):
    sel = [r for r in rows if r["layers"] == layers]
    for i, r in enumerate(sel):
        t, mb, lossless = float(r["ms_write_median"]), float(r["mb_per_frame"]), r["lossless"] == "1"
        ax.scatter(t, mb, s=60, color="C0" if lossless else "C3",
                   facecolors=None if lossless else "none")
        ax.annotate(r["compression"], (t, mb), textcoords="offset points",
                    xytext=(6, 6 if i % 2 == 0 else -12), fontsize=9)
    ax.set_xlabel("ms to write one frame (median, log scale)")
    ax.set_ylabel("MB per frame")
    ax.set_title(f"layers {layers} ({sel[0]['channels']} channels)", fontsize=10)
    ax.set_xscale("log")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
axes[0].scatter([], [], color="C0", label="lossless")
axes[0].scatter([], [], color="C3", facecolors="none", label="lossy (float/half channels)")
axes[0].legend(fontsize=8, loc="upper right")
fig.suptitle("OpenEXR compressions on the typed night layers (photosite bench exr)\n" + (notes[0] if notes else ""),
             fontsize=9)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
