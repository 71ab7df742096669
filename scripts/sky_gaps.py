#!/usr/bin/env python3
"""Sky seen through foliage: how much of a frame's vegetation label is day sky, and how bright
photosite's night renders it against the rest of the vegetation.

Cityscapes and KITTI label tree crowns as polygons, so the sky between the crown's leaves and
around its edge is labelled vegetation. In the day photo those pixels are sky-bright; photosite
takes them as vegetation of that (capped) reflectance and lights them, so crowns against the
sky get a bright rim at night where a real night photo shows the dark sky. This script measures
that, per frame of ../shared/data (Cityscapes labelIds, KITTI semantic): a vegetation pixel
(label 21) is "sky-like" when its day luminance (linear sRGB, Rec. 709 weights) is at least
--fraction of the median luminance of the frame's sky pixels (label 23, at least 100 of them).
It then runs `photosite night` on the frame and compares the median luminance of the night radiance
(the `night_radiance` layer, the same Rec. 709 weights; medians, as lamp heads drawn over a few
sky pixels would set a mean) over the sky-like vegetation pixels, over the rest of the vegetation,
and over the sky.

    /usr/bin/python3 scripts/sky_gaps.py --photosite build/photosite --shared ../shared [--fraction 0.6]

Needs oiiotool (the layer's luminance to a float TIFF) and python3-pil / numpy (Debian).
"""
import argparse
import glob
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

W709 = np.array([0.2126, 0.7152, 0.0722])


def linear(srgb8):
    a = srgb8.astype(np.float64) / 255
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)


def frames(shared):
    out = []
    for f in sorted(glob.glob(os.path.join(shared, "data/cityscapes/leftImg8bit/*_leftImg8bit.png"))):
        stem = os.path.basename(f)[: -len("_leftImg8bit.png")]
        lab = os.path.join(shared, "data/cityscapes/gtFine", stem + "_gtFine_labelIds.png")
        out.append((stem, f, lab))
    for f in sorted(glob.glob(os.path.join(shared, "data/kitti/image_2/*.png"))):
        out.append(("kitti_" + os.path.basename(f)[:-4], f, f.replace("image_2", "semantic")))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photosite", required=True, help="the photosite program")
    ap.add_argument("--shared", default="../shared", help="the shared data folder")
    ap.add_argument("--fraction", type=float, default=0.6, help="sky-like: day luminance ≥ this × the sky's median")
    a = ap.parse_args()
    rows = frames(a.shared)
    if not rows:
        print(f"sky_gaps.py: no frames under {a.shared}/data", file=sys.stderr)
        return 2
    print("frame | vegetation px | sky-like | share | night L: sky-like veg | other veg | sky | sky-like / other")
    with tempfile.TemporaryDirectory() as tmp:
        for stem, img, lab in rows:
            day = np.asarray(Image.open(img).convert("RGB"))
            ids = np.asarray(Image.open(lab))
            Y = linear(day) @ W709
            sky, veg = ids == 23, ids == 21
            if sky.sum() < 100 or veg.sum() == 0:
                print(f"{stem} | {veg.sum()} | – (sky {sky.sum()} px) | | | | |")
                continue
            gap = veg & (Y >= a.fraction * np.median(Y[sky]))
            exr = os.path.join(tmp, stem + ".exr")
            subprocess.run([a.photosite, "night", "--image", img, "--labels", lab, "--out", exr, "-y"], check=True,
                           stdout=subprocess.DEVNULL)
            tif = os.path.join(tmp, stem + ".tif")
            subprocess.run(["oiiotool", exr, "--ch", "night_radiance.R,night_radiance.G,night_radiance.B",
                            "--chsum:weight=0.2126,0.7152,0.0722", "-d", "float", "-o", tif], check=True)
            L = np.asarray(Image.open(tif), dtype=np.float64)
            other = veg & ~gap
            lg, lo, ls = (float(np.median(L[m])) if m.any() else float("nan") for m in (gap, other, sky))
            print(f"{stem} | {veg.sum()} | {gap.sum()} | {100 * gap.sum() / veg.sum():.2f} % | {lg:.3g} | {lo:.3g} | "
                  f"{ls:.3g} | {lg / lo:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
