#!/usr/bin/python3
"""Before/after pictures of the façade planes (issue 14 §2, windows on façades) for docs/night.md.

Runs `photosite night --seed 1` of this checkout (after) and of an older build (before) on the
bundled KITTI frame and on Cityscapes aachen_000000_000019 (../shared), and writes under docs/night/:
  facade_<scene>_before.jpg, facade_<scene>_after.jpg   camera preview above, light map below
                                                         (log10 luminance, the `--maps` picture)
Usage: scripts/facade_figures.py --before /path/to/old/photosite [--before-presets /path/to/its/presets]
           [--prefix facade] [--cityscapes aachen_000000_000019]
--prefix names the pictures (<prefix>_<scene>_before.jpg ...); --cityscapes picks the Cityscapes frame.
The photo's windows against the grid (docs/night.md §7) were made with this build as both, the grid's
presets a copy with windows.detect_contrast = 0:
  scripts/facade_figures.py --before build/photosite --before-presets /tmp/grid_presets --prefix windows
      --cityscapes aachen_000004_000019
"""
import argparse
import os
import subprocess
import tempfile

from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared", "data")
OUT = os.path.join(ROOT, "docs", "night")


def scenes(n):
    cs = os.path.join(SHARED, "cityscapes")
    yield "kitti", [], "kitti"
    yield "cityscapes_" + n.split("_")[1], [
        "--image", os.path.join(cs, "leftImg8bit", n + "_leftImg8bit.png"),
        "--labels", os.path.join(cs, "gtFine", n + "_gtFine_labelIds.png"),
        "--instances", os.path.join(cs, "gtFine", n + "_gtFine_instanceIds.png")], "cityscapes"


def render(exe, args, rig, tmp, preset_dir=None):
    os.makedirs(tmp, exist_ok=True)
    cmd = [exe, "night", *args, "--rig", rig, "--out", os.path.join(tmp, "n.exr"), "--preview",
           os.path.join(tmp, "n.png"), "--maps", tmp, "--overwrite", "--seed", "1", "--backend", "cpu"]
    print(" ".join(cmd))
    env = dict(os.environ)
    if preset_dir:
        env["PHOTOSITE_PRESET_DIR"] = preset_dir
    subprocess.run(cmd, check=True, env=env)
    a = Image.open(os.path.join(tmp, "n.png")).convert("RGB")
    b = Image.open(os.path.join(tmp, "lights_log.png")).convert("RGB").resize(a.size)
    both = Image.new("RGB", (a.width, 2 * a.height))
    both.paste(a, (0, 0))
    both.paste(b, (0, a.height))
    width = 1024
    if both.width > width:
        both = both.resize((width, round(both.height * width / both.width)), Image.LANCZOS)
    return both


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="an older photosite binary for the 'before' pictures")
    ap.add_argument("--before-presets", help="the presets folder of that version (PHOTOSITE_PRESET_DIR), when its "
                    "compiled-in one has moved on")
    ap.add_argument("--prefix", default="facade", help="the pictures' names begin with it")
    ap.add_argument("--cityscapes", default="aachen_000000_000019", help="the Cityscapes frame (../shared)")
    a = ap.parse_args()
    os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    os.makedirs(OUT, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name, args, rig in scenes(a.cityscapes):
            for tag, exe, pd in (("after", os.path.join(ROOT, "build", "photosite"), os.path.join(ROOT, "presets")),
                                 ("before", a.before, a.before_presets)):
                im = render(exe, args, rig, os.path.join(tmp, name + "_" + tag), pd)
                im.save(os.path.join(OUT, "%s_%s_%s.jpg" % (a.prefix, name, tag)), quality=85)
    print("wrote", OUT)


if __name__ == "__main__":
    main()
