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
import tempfile

from PIL import Image, ImageDraw

from night_figures import OUT, ROOT, run  # the same `photosite night` call as the other pictures


def preview(exe, tmp):
    run(exe, [], tmp, maps=False)  # the bundled KITTI frame
    return Image.open(os.path.join(tmp, "n.png")).convert("RGB")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="an older photosite binary (without the beam on vertical surfaces)")
    a = ap.parse_args()
    os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    with tempfile.TemporaryDirectory() as tmp:
        after = preview(os.path.join(ROOT, "build", "photosite"), os.path.join(tmp, "after"))
        before = preview(a.before, os.path.join(tmp, "before"))
    w, h = after.size
    box = (0, h // 3, w, h)  # the road and what stands on it
    parts = [(before.crop(box), "before: the low beam on the road only"),
             (after.crop(box), "after: also on cars, fences, poles and crowns ahead")]
    ph = box[3] - box[1]
    out = Image.new("RGB", (w, 2 * ph))
    for k, (im, label) in enumerate(parts):
        out.paste(im, (0, k * ph))
        ImageDraw.Draw(out).text((8, k * ph + 6), label, fill=(255, 255, 0))
    if out.width > 1024:
        out = out.resize((1024, round(out.height * 1024 / out.width)), Image.LANCZOS)
    os.makedirs(OUT, exist_ok=True)
    dst = os.path.join(OUT, "beam_vertical_kitti.jpg")
    out.save(dst, quality=85)
    print("wrote", dst)


if __name__ == "__main__":
    main()
