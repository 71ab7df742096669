#!/usr/bin/python3
"""Before/after pictures of the metric night scene for docs/night.md (issue 14).

Runs `photosite night` of this checkout (after) and, when given, another build (before, e.g. main
before the metric scene) on three scenes: the bundled KITTI frame and two Cityscapes frames from
../shared. Writes pictures under docs/night/:
  <scene>_before.jpg, <scene>_after.jpg   camera previews (at most 1024 px wide)
  <scene>_depth_m.png                      metric depth.Z with a colour bar in metres
  <scene>_lights_log.jpg                   the light map, log10 luminance 1e-3..1e3 cd/m²
Usage: scripts/night_figures.py [--before /path/to/old/photosite]
"""
import argparse
import os
import subprocess
import tempfile

import matplotlib
from PIL import Image, ImageDraw

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared", "data")
OUT = os.path.join(ROOT, "docs", "night")


def scenes():
    cs = os.path.join(SHARED, "cityscapes")
    yield "kitti", [], "kitti"
    for n in ("aachen_000000_000019", "aachen_000001_000019"):
        yield ("cityscapes_" + n.split("_")[1], [
            "--image", os.path.join(cs, "leftImg8bit", n + "_leftImg8bit.png"),
            "--labels", os.path.join(cs, "gtFine", n + "_gtFine_labelIds.png"),
            "--instances", os.path.join(cs, "gtFine", n + "_gtFine_instanceIds.png")], "cityscapes")


def kitti_after_before(before_exe, read):
    """`photosite night` of this checkout and of `before_exe` on the bundled KITTI frame (through
    run, in a temporary folder each); returns (read(after folder), read(before folder)), `read`
    taking what it needs from the folder (n.exr, n.png) before the folders are removed."""
    os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    with tempfile.TemporaryDirectory() as tmp:
        got = []
        for exe, sub in ((os.path.join(ROOT, "build", "photosite"), "after"), (before_exe, "before")):
            run(exe, [], os.path.join(tmp, sub), maps=False)
            got.append(read(os.path.join(tmp, sub)))
    return got[0], got[1]


def save_stacked(parts, name, width=1024):
    """Stacks (image, label) pairs of one size one above the other, each labelled in its corner,
    and writes them as docs/night/<name> (a JPEG at most `width` px wide)."""
    w, ph = parts[0][0].size
    out = Image.new("RGB", (w, len(parts) * ph))
    for k, (im, label) in enumerate(parts):
        out.paste(im, (0, k * ph))
        ImageDraw.Draw(out).text((8, k * ph + 6), label, fill=(255, 255, 0))
    if out.width > width:
        out = out.resize((width, round(out.height * width / out.width)), Image.LANCZOS)
    os.makedirs(OUT, exist_ok=True)
    dst = os.path.join(OUT, name)
    out.save(dst, quality=85)
    print("wrote", dst)


def save_small(src, dst, width=1024):
    """Copies a PNG as a JPEG at most `width` px wide (docs stay small)."""
    im = Image.open(src).convert("RGB")
    if im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
    im.save(dst, quality=85)


def run(exe, args, tmp, maps=True, rig=None):
    os.makedirs(tmp, exist_ok=True)
    cmd = [exe, "night", *args, "--out", os.path.join(tmp, "n.exr"), "--preview", os.path.join(tmp, "n.png"),
           "--overwrite", "--seed", "1"]
    if maps:
        cmd += ["--maps", tmp]
    if rig:
        cmd += ["--rig", rig]
    print(" ".join(cmd))
    subprocess.run(cmd, check=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="an older photosite binary for the 'before' previews")
    a = ap.parse_args()
    exe = os.path.join(ROOT, "build", "photosite")
    os.makedirs(OUT, exist_ok=True)
    env_store = os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    del env_store
    with tempfile.TemporaryDirectory() as tmp:
        for name, args, rig in scenes():
            after = os.path.join(tmp, name + "_after")
            run(exe, args, after, rig=rig)
            save_small(os.path.join(after, "n.png"), os.path.join(OUT, name + "_after.jpg"))
            if a.before:
                before = os.path.join(tmp, name + "_before")
                run(a.before, args, before, maps=False)
                save_small(os.path.join(before, "n.png"), os.path.join(OUT, name + "_before.jpg"))
            # depth.png holds 1 - log10(z)/3 (1 m white .. 1000 m black, sky black): back to metres.
            v = plt.imread(os.path.join(after, "depth.png"))
            if v.ndim == 3:
                v = v[..., 0]
            z = 10 ** (3 * (1 - v))
            fig, ax = plt.subplots(figsize=(8, 8 * z.shape[0] / z.shape[1] + 0.6))
            im = ax.imshow(np.log10(z), cmap="turbo_r", vmin=0, vmax=3)
            ax.set_axis_off()
            cb = fig.colorbar(im, ax=ax, orientation="horizontal", fraction=0.05, pad=0.02)
            cb.set_ticks([0, 1, np.log10(30), 2, 3])
            cb.set_ticklabels(["1 m", "10 m", "30 m", "100 m", "≥1000 m (sky 65504)"])
            cb.set_label("depth.Z (m), flat ground + vertical planes")
            fig.savefig(os.path.join(OUT, name + "_depth_m.png"), dpi=100, bbox_inches="tight")
            plt.close(fig)
            save_small(os.path.join(after, "lights_log.png"), os.path.join(OUT, name + "_lights_log.jpg"))
    print("wrote", OUT)


if __name__ == "__main__":
    main()
