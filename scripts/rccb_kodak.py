#!/usr/bin/python3
"""Kodak CPSNR of every demosaic method on an RCCB (and RCCC) mosaic (docs/demosaic.md, "RCCB").

The clear pixel is photosite's box-basis model, C = R + G + B (docs/sensor.md section 8); the
score is docs/demosaic.md's protocol (8-bit rounding, a 10-pixel border left out). Columns:
  rccb_mean_cpsnr_db, rccb_worst_db   the library's RCCB demosaic (`ps.demosaic(m, "RCCB", ...)`)
  clear_as_green_mean_cpsnr_db        C fed in as green as it is, G = C - R - B after (through the
                                      RGGB code: what the library did before it scaled C)
  clear_<s>_mean_cpsnr_db             C times s as green, G = Ĝ/s - R - B after (C as it is at its
                                      own sites), for s = 1/2, 1/4 (the powers of two nearest 1/3)
                                      and 1/3 (clear_scaled_mean_cpsnr_db: the box basis's C/G on a
                                      grey and the library's factor, so the same as rccb_mean)
  rccc_mean_cpsnr_db                  RCCC, scored against what it can represent (R, and
                                      G = B = (G + B)/2): every method takes the generic path

Usage: PYTHONPATH=build/python /usr/bin/python3 scripts/rccb_kodak.py [--kodak ../shared/data/kodak24]
"""
import argparse
import glob
import os
import sys

import numpy as np
import photosite as ps

METHODS = ["bilinear", "malvar", "hamilton-adams", "lmmse", "mlri"]
SCALES = {"half": 0.5, "scaled": 1.0 / 3.0, "quarter": 0.25}


def cpsnr(truth, out):
    ref = np.round(truth * 255)
    o = np.round(np.clip(out, 0, 1) * 255)
    d = (o - ref)[10:-10, 10:-10].astype(float)
    return 10 * np.log10(255 ** 2 / np.mean(d ** 2))


def mosaic(img, clear_scale, pattern="RCCB"):
    c = (img.sum(-1) * clear_scale).astype(np.float32)
    m = np.zeros(img.shape[:2], np.float32)
    m[0::2, 0::2] = img[0::2, 0::2, 0]
    m[0::2, 1::2] = c[0::2, 1::2]
    m[1::2, 0::2] = c[1::2, 0::2]
    m[1::2, 1::2] = img[1::2, 1::2, 2] if pattern == "RCCB" else c[1::2, 1::2]
    return m


def clear_as_green(img, m, s):
    """The RGGB method on C*s as green, G = (C_hat - R) - B after, C_hat the clear sample at its
    own site and Ĝ/s elsewhere (float32, in the library's order)."""
    y = ps.demosaic(mosaic(img, s), "RGGB", m, backend="cpu")
    c_hat = np.float32(1.0 / s) * y[..., 1] if s != 1.0 else y[..., 1]
    clear = np.zeros(img.shape[:2], bool)
    clear[0::2, 1::2] = clear[1::2, 0::2] = True
    c_hat = np.where(clear, mosaic(img, 1.0), c_hat)
    return np.stack([y[..., 0], (c_hat - y[..., 0]) - y[..., 2], y[..., 2]], -1)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kodak", default=os.path.join(here, "..", "..", "shared", "data", "kodak24"))
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.kodak, "kodim*.png")))
    if not files:
        sys.exit(f"rccb_kodak.py: no kodim*.png in {a.kodak} (--kodak names the Kodak folder)")
    cols = ["rccb", "clear_as_green"] + list(SCALES) + ["rccc"]
    score = {m: {c: [] for c in cols} for m in METHODS}
    same = 0  # (image, method) pairs where the library's RCCB equals the C/3 emulation bit for bit
    for f in files:
        img = ps.read_image(f).astype(np.float32)
        rccc_truth = img.copy()
        rccc_truth[..., 1] = rccc_truth[..., 2] = 0.5 * (img[..., 1] + img[..., 2])
        for m in METHODS:
            s = score[m]
            lib = ps.demosaic(mosaic(img, 1.0), "RCCB", m, backend="cpu")
            s["rccb"].append(cpsnr(img, lib))
            s["clear_as_green"].append(cpsnr(img, clear_as_green(img, m, 1.0)))
            for name, k in SCALES.items():
                out = clear_as_green(img, m, k)
                s[name].append(cpsnr(img, out))
                if name == "scaled" and m != "bilinear":
                    same += np.array_equal(lib, out)
            s["rccc"].append(cpsnr(rccc_truth, ps.demosaic(mosaic(img, 1.0, "RCCC"), "RCCC", m, backend="cpu")))
    print("method,rccb_mean_cpsnr_db,rccb_worst_db,clear_as_green_mean_cpsnr_db,clear_half_mean_cpsnr_db,"
          "clear_scaled_mean_cpsnr_db,clear_quarter_mean_cpsnr_db,rccc_mean_cpsnr_db")
    for m in METHODS:
        s = score[m]
        print(f"{m},{np.mean(s['rccb']):.3f},{min(s['rccb']):.3f},{np.mean(s['clear_as_green']):.3f},"
              f"{np.mean(s['half']):.3f},{np.mean(s['scaled']):.3f},{np.mean(s['quarter']):.3f},{np.mean(s['rccc']):.3f}")
    print(f"# the library's RCCB equals the C/3 emulation bit for bit on {same} of {len(files) * (len(METHODS) - 1)}"
          " (image, method) pairs (bilinear reads C as it is)")


if __name__ == "__main__":
    main()
