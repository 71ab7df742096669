#!/usr/bin/python3
"""Chart for `photosite bench demosaic`: Kodak CPSNR (left) and saturated-set CPSNR (right, when
the CSV has the sat_cpsnr_db column) against ms per 2048x1024 frame, one point per method and
input type (photosite on float, OpenCV on its 8/16-bit inputs), with the memory floor (read the
mosaic + write the RGB image) as a vertical line.
Usage: chart_demosaic.py demosaic.csv demosaic.png"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def plot_panel(ax, rows, floor, column, ylabel):
    stacked = 0
    for r in rows:
        ours = r["implementation"] == "photosite"
        x, y = float(r["ms_per_frame"]), float(r[column])
        marker = "o" if ours else ("s" if r["input"] == "uint8" else "D")
        color = "tab:blue" if ours else "tab:orange"
        ax.scatter([x], [y], marker=marker, s=60, color=color, zorder=3)
        name = r["method"] if ours else f"OpenCV {r['method']} ({r['input']})"
        # photosite's labels beside their points; OpenCV's 8-bit ones stacked above, 16-bit ones
        # below (the linear methods' points nearly coincide at 30.2 dB).
        if ours:
            off = (6, 4)
        elif r["input"] == "uint8":
            off = (-4, 8 + 12 * stacked)
            stacked += 1
        else:
            off = (6, -11)
        ax.annotate(name, (x, y), textcoords="offset points", xytext=off, fontsize=8)
    if floor:
        ax.axvline(floor, color="grey", ls="--", lw=1)
        ax.axvline(2 * floor, color="grey", ls=":", lw=1)
        ax.text(floor, ax.get_ylim()[0] + 0.3, " memory floor", fontsize=8, color="grey")
        ax.text(2 * floor, ax.get_ylim()[0] + 1.0, " 2x floor", fontsize=8, color="grey")
    ax.set_xscale("log")
    ax.set_xlabel("ms per 2048x1024 frame (log scale)")
    ax.set_ylabel(ylabel)
    ax.set_title("Demosaicing: accuracy vs speed (photosite: blue, float in/out; OpenCV: orange)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)


def main(csv_path, png_path):
    rows, floor, note = [], None, ""
    with open(csv_path) as f:
        lines = [l for l in f if not l.startswith("#")]
    with open(csv_path) as f:
        comments = [l[1:].strip() for l in f if l.startswith("#")]
    for r in csv.DictReader(lines):
        if r["implementation"] == "copy":
            floor = float(r["ms_per_frame"])
            continue
        rows.append(r)
    panels = [("kodak_cpsnr_db", "Kodak-24 mean CPSNR, dB (10-px border excluded)")]
    if rows and rows[0].get("sat_cpsnr_db"):
        panels.append(("sat_cpsnr_db", "saturated-set mean CPSNR, dB (Kodak tiles + charts)"))
    fig, axes = plt.subplots(1, len(panels), figsize=(8.5 * len(panels), 5.2), squeeze=False)
    for ax, (column, ylabel) in zip(axes[0], panels):
        plot_panel(ax, rows, floor, column, ylabel)
    if comments:
        fig.text(0.01, 0.01, comments[0][:150], fontsize=6.5, color="grey")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
