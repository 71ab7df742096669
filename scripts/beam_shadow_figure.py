#!/usr/bin/python3
"""Before/after of the low beam's shadows on the ground (docs/night.md §6c), for docs/night/.

Runs `photosite night` of this checkout (after) and an older build given with --before (main
before shade_low_beam_ground, e.g. 740432b) on the bundled KITTI frame through night_figures.run
(the same call as the other pictures) and writes docs/night/beam_shadow_kitti.jpg: the two
previews' lower halves one above the other, each labelled, and below them the after preview in
grey with the pixels whose night radiance fell (the shadows) in magenta. The previews are the
simple ISP's (their 99th percentile to white), each exposed for itself.
Usage: scripts/beam_shadow_figure.py --before /path/to/old/photosite
"""
import argparse
import os
import sys

import numpy as np
from PIL import Image

from night_figures import ROOT, kitti_after_before, save_stacked  # the same `photosite night` call as the other pictures

sys.path.insert(0, os.path.join(ROOT, "build", "python"))
import photosite as ps  # noqa: E402  (this checkout's module: read_exr)


def night(tmp):
    channels = ps.read_exr(os.path.join(tmp, "n.exr"))[0]
    return Image.open(os.path.join(tmp, "n.png")).convert("RGB"), channels["night_radiance.G"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="an older photosite binary (without the beam's shadows)")
    a = ap.parse_args()
    (after, g1), (before, g0) = kitti_after_before(a.before, night)
    shaded = g1 < g0
    print("pixels whose night radiance fell:", int(shaded.sum()))
    grey = np.asarray(after.convert("L"), dtype=np.float32)[..., None].repeat(3, axis=2)
    grey[shaded] = (255, 0, 255)
    mask = Image.fromarray(grey.astype(np.uint8))
    w, h = after.size
    box = (0, h // 3, w, h)  # the road and what stands on it
    save_stacked([(before.crop(box), "before: the low beam lights every ground point"),
                  (after.crop(box), "after: the ground behind cars, poles and walls loses the lamps they hide"),
                  (mask.crop(box), "the ground pixels whose night radiance fell (magenta)")], "beam_shadow_kitti.jpg")


if __name__ == "__main__":
    main()
