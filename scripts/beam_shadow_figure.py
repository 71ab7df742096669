#!/usr/bin/python3
"""The low beam's shadows (docs/night.md §6c) on the bundled KITTI frame, for docs/night/.

Ground (--before): runs `photosite night` of this checkout (after) and an older build given with
--before (main before shade_low_beam_ground, e.g. 740432b) on the bundled KITTI frame through
night_figures.run (the same call as the other pictures) and writes docs/night/beam_shadow_kitti.jpg:
the two previews' lower halves one above the other, each labelled, and below them the after preview
in grey with the pixels whose night radiance fell (the shadows) in magenta.

Vertical surfaces (--vertical): runs this checkout's `photosite night` twice, with the
night-urban preset (ego_beam.shadows = true) and with a copy of it whose only change is
ego_beam.shadows = false, and writes docs/night/beam_shadow_vertical_kitti.jpg: the two previews'
lower two thirds and the shadows-on preview in grey with the vertical-surface pixels (every class
but the ground classes, scene/labels.cpp is_ground) whose night radiance fell in magenta and the
ground pixels whose night radiance fell in green. Prints the vertical pixels that fell per class
and the EXR header's photosite/night/beam_shadow_vertical_{left,right,both}_pixels.

Street lamps (--street): the same with the preset's [street_lamps] shadows switched off instead,
written as docs/night/street_shadow_kitti.jpg: the two previews' lower two thirds and the
shadows-on preview in grey with the pixels whose night radiance fell in magenta (docs/night.md §7,
"Shadows of the street lamps").

Penumbrae (--penumbrae): this checkout's `photosite night` with the night-urban preset (the street
lamps' penumbrae off: sharp edges) and with a copy whose only change is [street_lamps] penumbrae =
true, on Cityscapes aachen_000000 (../shared), written as docs/night/street_penumbra_cityscapes.jpg: the
240 x 100 px window holding the most changed pixels, enlarged 3x, of both previews, and the pixels
whose night radiance fell (magenta) or rose (green) over the grey preview (docs/night.md §7,
"Penumbrae").

The previews are the simple ISP's (their 99th percentile to white), each exposed for itself.
Usage: scripts/beam_shadow_figure.py --before /path/to/old/photosite
       scripts/beam_shadow_figure.py --vertical
       scripts/beam_shadow_figure.py --street
       scripts/beam_shadow_figure.py --penumbrae
"""
import argparse
import os
import re
import sys
import tempfile

import numpy as np
from PIL import Image

from night_figures import ROOT, kitti_after_before, run, save_stacked, scenes  # the same `photosite night` call as the other pictures

sys.path.insert(0, os.path.join(ROOT, "build", "python"))
import photosite as ps  # noqa: E402  (this checkout's module: read_exr)

GROUND_IDS = (6, 7, 8, 9, 10, 22)  # scene/labels.cpp is_ground: ground, road, sidewalk, parking, rail track, terrain
CLASS_NAMES = {4: "static", 5: "dynamic", 11: "building", 12: "wall", 13: "fence", 17: "pole", 19: "traffic light",
               21: "vegetation", 24: "person", 25: "rider", 26: "car", 27: "truck", 28: "bus", 32: "motorcycle",
               33: "bicycle"}


def night(tmp):
    channels, attrs = ps.read_exr(os.path.join(tmp, "n.exr"))[:2]
    return Image.open(os.path.join(tmp, "n.png")).convert("RGB"), channels, attrs


def lower(im, h):
    return im.crop((0, h // 3, im.size[0], h))  # the road and what stands on it


def fell_figure(without, with_, fell, grey_scale, labels, name):
    """Three panels: `without` and `with_`'s lower parts, and `with_` in grey (times grey_scale) with the
    pixels in `fell` in magenta; labels: the first two panels' captions."""
    grey = np.asarray(with_.convert("L"), dtype=np.float32)[..., None].repeat(3, axis=2) * grey_scale
    grey[fell] = (255, 0, 255)
    mask = Image.fromarray(grey.astype(np.uint8))
    h = with_.size[1]
    save_stacked([(lower(without, h), labels[0]), (lower(with_, h), labels[1]),
                  (lower(mask, h), "the ground pixels whose night radiance fell (magenta)")], name)


def ground_figure(before_exe):
    (after, c1, _), (before, c0, _) = kitti_after_before(before_exe, night)
    shaded = c1["night_radiance.G"] < c0["night_radiance.G"]
    print("pixels whose night radiance fell:", int(shaded.sum()))
    fell_figure(before, after, shaded, 1.0,
                ("before: the low beam lights every ground point",
                 "after: the ground behind cars, poles and walls loses the lamps they hide"), "beam_shadow_kitti.jpg")


def switched_preset(tmp, table, key="shadows", value="true", to="false"):
    """A copy of presets/scenes/night-urban.toml whose [table]'s `key = value` line reads `to` (the only
    change), written into tmp; returns its path."""
    with open(os.path.join(ROOT, "presets", "scenes", "night-urban.toml")) as f:
        lines = f.read().split("\n")
    section, n = None, 0
    for i, line in enumerate(lines):
        m = re.match(r"^\[([A-Za-z_]+)\]", line)
        if m:
            section = m.group(1)
        elif section == table and re.match(rf"^{key} = {value}\b", line):
            lines[i] = re.sub(rf"^{key} = {value}", f"{key} = {to}", line)
            n += 1
    if n != 1:
        sys.exit(f"presets/scenes/night-urban.toml: no single '{key} = {value}' line in [{table}] to switch")
    path = os.path.join(tmp, f"night-urban-{table}-{key}-{to}.toml")
    with open(path, "w") as f:
        f.write("\n".join(lines))
    return path


def on_off(table, key="shadows", value="true", to="false", args=()):
    """This checkout's `photosite night` on the bundled KITTI frame (or the frame `args` name) with the
    night-urban preset and with its [table]'s `key = value` switched to `to`: ((preview, channels,
    attrs) as bundled, (preview, channels, attrs) switched)."""
    os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    exe = os.path.join(ROOT, "build", "photosite")
    with tempfile.TemporaryDirectory() as tmp:
        switched = switched_preset(tmp, table, key, value, to)
        run(exe, [*args], os.path.join(tmp, "on"), maps=False)
        run(exe, [*args, "--scene-preset", switched], os.path.join(tmp, "off"), maps=False)
        return night(os.path.join(tmp, "on")), night(os.path.join(tmp, "off"))


def street_figure():
    (on, c1, a1), (off, c0, _) = on_off("street_lamps")
    fell = c1["night_radiance.G"] < c0["night_radiance.G"]
    print("pixels whose night radiance fell:", int(fell.sum()), "; header street_lamp_shadow_pixels:",
          a1["photosite/night/street_lamp_shadow_pixels"])
    fell_figure(off, on, fell, 0.8,
                ("street_lamps.shadows = false: the pools run under every car and pole",
                 "street_lamps.shadows = true: cars, poles and signs hide the lamps behind them"), "street_shadow_kitti.jpg")


def penumbra_figure():
    """The street lamps' penumbrae (street_lamps.penumbrae, off in the bundled presets: the sharp edges)
    against a copy switching them on, on Cityscapes aachen_000000 (f 2263 px: penumbrae of many pixels;
    the bundled KITTI frame's are 1-2 px): a crop of the previews where most pixels changed, enlarged
    3x, and the changed pixels (darker magenta, brighter green) over the grey preview."""
    frame = [a for name, a, _ in scenes() if name == "cityscapes_000000"][0]
    (sharp, c0, _), (soft, c1, a1) = on_off("street_lamps", "penumbrae", "false", "true", frame)
    g0, g1 = c0["night_radiance.G"], c1["night_radiance.G"]
    darker, brighter = g1 < g0, g1 > g0
    changed = darker | brighter
    print("pixels changed:", int(changed.sum()), "darker", int(darker.sum()), "brighter", int(brighter.sum()),
          "; header street_lamp_shadow_pixels:", a1["photosite/night/street_lamp_shadow_pixels"])
    # The crop: the 240 x 100 px window (on a 10 px grid) holding the most changed pixels.
    h, w = changed.shape
    ii = np.pad(changed.astype(np.int64).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    best, x0, y0 = -1, 0, 0
    for y in range(0, h - 100 + 1, 10):
        for x in range(0, w - 240 + 1, 10):
            n = ii[y + 100, x + 240] - ii[y, x + 240] - ii[y + 100, x] + ii[y, x]
            if n > best:
                best, x0, y0 = n, x, y
    box = (x0, y0, x0 + 240, y0 + 100)
    grey = np.asarray(soft.convert("L"), dtype=np.float32)[..., None].repeat(3, axis=2) * 0.8
    grey[darker] = (255, 0, 255)
    grey[brighter] = (0, 200, 0)
    mask = Image.fromarray(grey.astype(np.uint8))
    big = lambda im: im.crop(box).resize((720, 300), Image.NEAREST)  # noqa: E731
    save_stacked([(big(sharp), f"street_lamps.penumbrae = false: sharp edges (crop at x {x0}, y {y0}, 3x)"),
                  (big(soft), "street_lamps.penumbrae = true: the face a 0.5 m disc, the edges soft"),
                  (big(mask), "pixels whose night radiance fell (magenta) or rose (green)")],
                 "street_penumbra_cityscapes.jpg", width=720)


def vertical_figure():
    (on, c1, a1), (off, c0, _) = on_off("ego_beam")
    fell = c1["night_radiance.G"] < c0["night_radiance.G"]
    labels = c1["labels.Y"].astype(np.int32)
    ground = np.isin(labels, GROUND_IDS)
    vertical_fell, ground_fell = fell & ~ground, fell & ground
    print("vertical-surface pixels whose night radiance fell:", int(vertical_fell.sum()),
          "(ground:", int(ground_fell.sum()), ")")
    for k in np.unique(labels[vertical_fell]):
        n = int((vertical_fell & (labels == k)).sum())
        print(f"  {CLASS_NAMES.get(int(k), 'class ' + str(int(k)))}: {n} of {int((labels == k).sum())}")
    print("header left / right / both:",
          " / ".join(a1[f"photosite/night/beam_shadow_vertical_{s}_pixels"] for s in ("left", "right", "both")))
    grey = np.asarray(on.convert("L"), dtype=np.float32)[..., None].repeat(3, axis=2) * 0.8
    grey[ground_fell] = (0, 200, 0)
    grey[vertical_fell] = (255, 0, 255)
    mask = Image.fromarray(grey.astype(np.uint8))
    h = on.size[1]
    save_stacked([(lower(off, h), "ego_beam.shadows = false: the lamps light every point"),
                  (lower(on, h), "ego_beam.shadows = true: walls, fences, trees and cars lose the lamps others hide"),
                  (lower(mask, h), "pixels whose night radiance fell: vertical surfaces (magenta), ground (green)")],
                 "beam_shadow_vertical_kitti.jpg")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="an older photosite binary (without the beam's shadows): the ground figure")
    ap.add_argument("--vertical", action="store_true", help="the vertical surfaces' figure (this checkout only)")
    ap.add_argument("--street", action="store_true",
                    help="the street lamps' shadows (street_lamps.shadows on and off; this checkout only)")
    ap.add_argument("--penumbrae", action="store_true",
                    help="the street lamps' penumbrae (street_lamps.penumbrae off and on; this checkout only)")
    a = ap.parse_args()
    if bool(a.before) + a.vertical + a.street + a.penumbrae != 1:
        ap.error("give one of --before PHOTOSITE (the ground figure), --vertical, --street or --penumbrae")
    if a.penumbrae:
        penumbra_figure()
    elif a.street:
        street_figure()
    elif a.vertical:
        vertical_figure()
    else:
        ground_figure(a.before)


if __name__ == "__main__":
    main()
