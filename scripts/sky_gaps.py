#!/usr/bin/env python3
"""Sky seen through foliage: how much of a frame's vegetation label is day sky, which of it
photosite takes for sky, and how bright photosite's night renders it against the rest of the
vegetation and the sky.

Cityscapes and KITTI label tree crowns as polygons, so the sky between the crown's leaves and
around its edge is labelled vegetation. This script measures that, per frame of ../shared/data
(Cityscapes labelIds, KITTI semantic): a vegetation pixel (label 21) is "sky-like" when its day
luminance (linear sRGB, Rec. 709 weights) is at least --fraction of the median luminance of the
frame's sky pixels (label 23, at least 100 of them), and "joined" when a chain of sky-like pixels
(8-neighbours) links it to the labelled sky: what photosite takes for sky (scene/sky_gaps.cpp,
reflectance.sky_gap_fraction; its EXR header's photosite/night/sky_gap_pixels is printed beside
this script's own count: photosite takes its sky median from a 1/16 sample, so the two may differ
by a few pixels). It then runs `photosite night` on the frame and compares the median luminance
of the night radiance (the `night_radiance` layer, the same Rec. 709 weights; medians, as lamp
heads drawn over a few sky pixels would set a mean) over the joined pixels, the sky-like ones not
joined, the crown's edge (the vegetation left beside the sky and the joined pixels, 8-neighbours:
what scene/sky_gaps.cpp unmix_sky_fringe scales to the leaf's share of the pixel), the rest of the
vegetation, and the sky.

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


def dilate8(mask):
    """The mask and its 8-neighbours."""
    out = mask.copy()
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    out[1:, 1:] |= mask[:-1, :-1]
    out[1:, :-1] |= mask[:-1, 1:]
    out[:-1, 1:] |= mask[1:, :-1]
    out[:-1, :-1] |= mask[1:, 1:]
    return out


def joined_to_sky(cand, sky):
    """The candidates that a chain of candidates (8-neighbours) links to the sky."""
    reach = sky.copy()
    while True:
        grown = dilate8(reach) & (cand | sky)
        if (grown == reach).all():
            return reach & cand
        reach = grown


def header_int(exr, name):
    out = subprocess.run(["oiiotool", "--info", "-v", exr], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if name in line:
            return int(line.split(":")[-1].strip())
    return None


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
    print("frame | vegetation px | sky-like | joined (header) | edge px | night L median: joined | sky-like, not joined | "
          "edge | other veg | sky | joined / other veg | joined / sky | edge / other veg")
    with tempfile.TemporaryDirectory() as tmp:
        for stem, img, lab in rows:
            day = np.asarray(Image.open(img).convert("RGB"))
            ids = np.asarray(Image.open(lab))
            Y = linear(day) @ W709
            sky, veg = ids == 23, ids == 21
            if sky.sum() < 100 or veg.sum() == 0:
                print(f"{stem} | {veg.sum()} | – (sky {sky.sum()} px) | | | | | | | | | | |")
                continue
            like = veg & (Y >= a.fraction * np.median(Y[sky]))
            joined = joined_to_sky(like, sky)
            edge = veg & ~joined & dilate8(sky | joined)
            exr = os.path.join(tmp, stem + ".exr")
            subprocess.run([a.photosite, "night", "--image", img, "--labels", lab, "--out", exr, "-y"], check=True,
                           stdout=subprocess.DEVNULL)
            taken = header_int(exr, "sky_gap_pixels")
            tif = os.path.join(tmp, stem + ".tif")
            subprocess.run(["oiiotool", exr, "--ch", "night_radiance.R,night_radiance.G,night_radiance.B",
                            "--chsum:weight=0.2126,0.7152,0.0722", "-d", "float", "-o", tif], check=True)
            L = np.asarray(Image.open(tif), dtype=np.float64)
            med = [float(np.median(L[m])) if m.any() else float("nan")
                   for m in (joined, like & ~joined, edge, veg & ~like & ~edge, sky)]
            print(f"{stem} | {veg.sum()} | {like.sum()} | {joined.sum()} ({taken}) | {edge.sum()} | "
                  + " | ".join(f"{v:.3g}" for v in med)
                  + f" | {med[0] / med[3]:.2f} | {med[0] / med[4]:.2f} | {med[2] / med[3]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
