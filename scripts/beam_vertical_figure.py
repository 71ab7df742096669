#!/usr/bin/python3
"""Before/after of the ego low beam on vertical surfaces (docs/night.md §6c), for docs/night/.

Runs `photosite night` of this checkout (after) and an older build given with --before (main
before add_low_beam_vertical, e.g. 4dd7a3e) on the bundled KITTI frame (its parked cars and
fences along the street) and writes docs/night/beam_vertical_kitti.jpg: the two previews'
lower halves one above the other, each labelled. The previews are the simple ISP's (their 99th
percentile to white), so the two are exposed each for itself; the radiance difference itself is
in the EXRs (`night_radiance`).
Usage: scripts/beam_vertical_figure.py --before /path/to/old/photosite
(An old binary reads only its own preset keys: give it its presets with PHOTOSITE_PRESET_DIR, e.g.
`git archive 4dd7a3e presets | tar -x -C DIR`; this checkout reads them too, the key
ego_beam.lens_diameter_m being optional.)
"""
import argparse
import os

from PIL import Image

from night_figures import kitti_after_before, save_stacked  # the same `photosite night` call as the other pictures


def preview(tmp):
    return Image.open(os.path.join(tmp, "n.png")).convert("RGB")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="an older photosite binary (without the beam on vertical surfaces)")
    a = ap.parse_args()
    after, before = kitti_after_before(a.before, preview)
    w, h = after.size
    box = (0, h // 3, w, h)  # the road and what stands on it
    save_stacked([(before.crop(box), "before: the low beam on the road only"),
                  (after.crop(box), "after: also on cars, fences, poles and crowns ahead")], "beam_vertical_kitti.jpg")


if __name__ == "__main__":
    main()
