#!/usr/bin/python3
"""Kodak CPSNR of every demosaic method on an RCCB mosaic (docs/demosaic.md, "RCCB").

The clear pixel is photosite's box-basis model, C = R + G + B (docs/sensor.md section 8); the
score is docs/demosaic.md's protocol (8-bit rounding, a 10-pixel border left out). Second, the
same methods with the clear samples scaled to green's level first (C/3 as the green stand-in of
an RGGB mosaic) and G = 3*G_hat - R - B after: what a fix in the library would give.

Usage: PYTHONPATH=build/python /usr/bin/python3 scripts/rccb_kodak.py [--kodak ../shared/data/kodak24]
"""
import argparse
import glob
import os
import sys

import numpy as np
import photosite as ps

METHODS = ["bilinear", "malvar", "hamilton-adams", "lmmse", "mlri"]


def cpsnr(truth, out):
    ref = np.round(truth * 255)
    o = np.round(np.clip(out, 0, 1) * 255)
    d = (o - ref)[10:-10, 10:-10].astype(float)
    return 10 * np.log10(255 ** 2 / np.mean(d ** 2))


def mosaic(img, clear_scale):
    c = img.sum(-1) * clear_scale
    m = np.zeros(img.shape[:2], np.float32)
    m[0::2, 0::2] = img[0::2, 0::2, 0]
    m[0::2, 1::2] = c[0::2, 1::2]
    m[1::2, 0::2] = c[1::2, 0::2]
    m[1::2, 1::2] = img[1::2, 1::2, 2]
    return m


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kodak", default=os.path.join(here, "..", "..", "shared", "data", "kodak24"))
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.kodak, "kodim*.png")))
    if not files:
        sys.exit(f"rccb_kodak.py: no kodim*.png in {a.kodak} (--kodak names the Kodak folder)")
    as_rccb = {m: [] for m in METHODS}
    scaled = {m: [] for m in METHODS}
    for f in files:
        img = ps.read_image(f).astype(np.float32)
        for m in METHODS:
            as_rccb[m].append(cpsnr(img, ps.demosaic(mosaic(img, 1.0), "RCCB", m, backend="cpu")))
            y = ps.demosaic(mosaic(img, 1.0 / 3.0), "RGGB", m, backend="cpu")
            scaled[m].append(cpsnr(img, np.stack([y[..., 0], 3 * y[..., 1] - y[..., 0] - y[..., 2], y[..., 2]], -1)))
    print("method,rccb_mean_cpsnr_db,rccb_worst_db,clear_scaled_mean_cpsnr_db")
    for m in METHODS:
        print(f"{m},{np.mean(as_rccb[m]):.3f},{min(as_rccb[m]):.3f},{np.mean(scaled[m]):.3f}")


if __name__ == "__main__":
    main()
