#!/usr/bin/python3
"""The horizon read off the cars in a frame's labels: a check of photosite's horizon on real
frames, which carry no ground truth for it (docs/night.md §2-6, "The horizon against the cars").

A car standing on flat ground, seen by a camera h metres above that ground, spans the image rows
from its roof's near edge y_t to its nearest ground contact y_b; the horizon is the row at the
camera's height on it, so with the car H metres tall

    y_h = y_b - (h / H) * (y_b - y_t)

(Hoiem, Efros and Hebert, "Putting Objects in Perspective", CVPR 2006, eq. 1, for small pitch:
the camera's 2.2 deg pitch scales both spans alike to within 1 - cos^2 = 0.15 %; the roof's near
edge and the contact lie up to a metre apart in depth, which moves y_h by f*h*(H-h)/H * dZ/Z^2,
under 1.5 px at 10 m for a Cityscapes car). Which car: the labels' car class (26), each instance
(Cityscapes instanceIds) or 8-connected region (KITTI, whose shared frames have no instances: a
region is kept only if at most 4 times as wide as tall, so rows of parked cars merged into one
region are left out), with

  * its contact seen: a ground class (ground, road, sidewalk, parking, rail track) directly below
    one of its lowest pixels;
  * its roof seen: no object that can stand in front of it (pole, sign, light, person, rider,
    vehicle) directly above one of its highest pixels;
  * not cut by the frame (no pixel in the outer column on either side or the last row), and at
    least 8 rows tall.

The cars' height is not known; H = 1.5 m is taken with the range 1.4-1.6 m as its uncertainty
(photosite's assumption: German saloons and hatchbacks stand 1.42-1.50 m, SUVs and vans 1.6-2.0
m; the class holds both). y_h's sensitivity to H is f*h/(H*Z) px per metre: 9 px per 0.1 m at 20
m for the Cityscapes rig, so a frame's near cars weigh little and the read-off is a check good to
some pixels, not a measurement to a pixel. The frame's value is the median over its cars, with
the standard error of a median, 1.2533 * sd / sqrt(n).

Runs `photosite night` of this checkout on each shared frame (5 Cityscapes, 3 KITTI) for the
horizon it takes; writes docs/horizon_vehicles.csv and prints the table.
Usage: scripts/horizon_from_vehicles.py [--shared ../shared] [--out docs/horizon_vehicles.csv]
"""

import argparse
import csv
import math
import os
import re
import subprocess
import sys
import tempfile
import tomllib

import numpy as np
from PIL import Image
from scipy import ndimage

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAR = 26
GROUND = {6, 7, 8, 9, 10}
IN_FRONT = {17, 18, 19, 20, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33}
H_CAR_M = (1.4, 1.5, 1.6)


def car_spans(label_ids, instance_ids=None):
    """(top row, bottom row) of each car whose roof and contact are seen, not cut by the frame."""
    if instance_ids is not None:
        ids = np.where(instance_ids // 1000 == CAR, instance_ids, 0)
        keys = [k for k in np.unique(ids) if k >= 1000]
        regions = [(ids == k) for k in keys]
    else:
        lab, n = ndimage.label(label_ids == CAR, structure=np.ones((3, 3), bool))
        regions = [(lab == k) for k in range(1, n + 1)]
    h, w = label_ids.shape
    out = []
    for m in regions:
        rows = np.flatnonzero(m.any(axis=1))
        cols = np.flatnonzero(m.any(axis=0))
        if rows.size == 0:
            continue
        top, bottom = int(rows[0]), int(rows[-1])
        if bottom - top + 1 < 8 or cols[0] == 0 or cols[-1] == w - 1 or bottom == h - 1:
            continue
        if instance_ids is None and cols[-1] - cols[0] + 1 > 4 * (bottom - top + 1):
            continue
        below = label_ids[bottom + 1][m[bottom]]
        above = label_ids[top - 1][m[top]] if top > 0 else np.array([], int)
        if not any(int(v) in GROUND for v in below):
            continue
        if top == 0 or all(int(v) in IN_FRONT for v in above):
            continue
        out.append((top, bottom))
    return out


def horizon_from_cars(spans, camera_height_m, car_height_m):
    """Per car y_h = y_b - (h/H)(y_b - y_t), y_t and y_b the silhouette's outer pixel edges: pixel
    centres at whole rows, as the rigs' principal points count them (OpenCV's convention), so the
    top row's upper edge is top - 0.5 and the bottom row's lower edge bottom + 0.5."""
    r = camera_height_m / car_height_m
    return [(b + 0.5) - r * ((b + 0.5) - (t - 0.5)) for t, b in spans]


def median_se(v):
    v = np.asarray(v, float)
    if v.size < 2:
        return float(np.median(v)) if v.size else math.nan, math.nan
    return float(np.median(v)), 1.2533 * float(np.std(v, ddof=1)) / math.sqrt(v.size)


def rig_nominal_horizon(rig, width):
    with open(os.path.join(ROOT, "presets", "rigs", rig + ".toml"), "rb") as f:
        r = tomllib.load(f)
    s = width / r["native_width_px"]  # the focal length and principal point scale with the width
    return s * (r["cy_px"] - r["fx_px"] * math.tan(math.radians(r["pitch_deg"]))), r["mount_height_m"]


def photosite_horizon(exe, image, labels, instances, tmp):
    cmd = [exe, "night", "--image", image, "--labels", labels, "--out", os.path.join(tmp, "n.exr"),
           "--overwrite", "--seed", "1"]
    if instances:
        cmd += ["--instances", instances]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    text = out.stdout + out.stderr
    m = re.search(r"horizon y ([-0-9.]+) px from the (vanishing point|rig's nominal pitch|\S+)", text)
    if not m:
        sys.exit(f"no horizon line in the output of {' '.join(cmd)}:\n{text}")
    h = re.search(r"height ([0-9.]+) m", text)
    return float(m.group(1)), {"vanishing point": "vp"}.get(m.group(2), "rig"), float(h.group(1))


def frames(shared):
    cs = os.path.join(shared, "data", "cityscapes")
    for i in range(5):
        n = f"aachen_00000{i}_000019"
        yield (n, "cityscapes", os.path.join(cs, "leftImg8bit", n + "_leftImg8bit.png"),
               os.path.join(cs, "gtFine", n + "_gtFine_labelIds.png"),
               os.path.join(cs, "gtFine", n + "_gtFine_instanceIds.png"))
    k = os.path.join(shared, "data", "kitti")
    for i in range(3):
        n = f"00000{i}_10"
        yield ("kitti_" + n, "kitti", os.path.join(k, "image_2", n + ".png"), os.path.join(k, "semantic", n + ".png"), None)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--shared", default=os.path.join(ROOT, "..", "shared"))
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "horizon_vehicles.csv"))
    a = ap.parse_args()
    if not os.path.isdir(os.path.join(a.shared, "data")):
        sys.exit(f"--shared {a.shared}: no data/ folder (the shared Cityscapes and KITTI frames)")
    exe = os.path.join(ROOT, "build", "photosite")
    os.environ.setdefault("PHOTOSITE_DEVICE_STORE", os.path.join(ROOT, "build", "figure-device-store"))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, rig, image, labels, instances in frames(a.shared):
            lab = np.asarray(Image.open(labels)).astype(np.int64)
            inst = np.asarray(Image.open(instances)).astype(np.int64) if instances else None
            y_ps, src, h_m = photosite_horizon(exe, image, labels, instances, tmp)
            y_rig, _ = rig_nominal_horizon(rig, lab.shape[1])
            spans = car_spans(lab, inst)
            est = {H: median_se(horizon_from_cars(spans, h_m, H)) for H in H_CAR_M}
            rows.append({"frame": name, "photosite_horizon_y": f"{y_ps:.1f}", "photosite_source": src,
                         "rig_nominal_horizon_y": f"{y_rig:.1f}", "camera_height_m": h_m, "cars": len(spans),
                         "cars_horizon_y_H1.5": f"{est[1.5][0]:.1f}", "cars_horizon_se_px": f"{est[1.5][1]:.1f}",
                         "cars_horizon_y_H1.4": f"{est[1.4][0]:.1f}", "cars_horizon_y_H1.6": f"{est[1.6][0]:.1f}"})
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    tmp_out = a.out + ".tmp"
    with open(tmp_out, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    os.replace(tmp_out, a.out)
    print(f"{'frame':22} {'photosite':>14} {'rig':>7} {'cars':>5} {'cars H=1.5 m (SE)':>18} {'H 1.4 .. 1.6 m':>16}")
    for r in rows:
        print(f"{r['frame']:22} {r['photosite_horizon_y']:>8} ({r['photosite_source']:>3}) {r['rig_nominal_horizon_y']:>7} "
              f"{r['cars']:>5} {r['cars_horizon_y_H1.5']:>10} ({r['cars_horizon_se_px']:>4}) "
              f"{r['cars_horizon_y_H1.4']:>7} .. {r['cars_horizon_y_H1.6']}")
    print("wrote", a.out)


if __name__ == "__main__":
    main()
