#!/usr/bin/env python3
"""Where RCCB's G = C - R - B goes negative, and what clipping it at 0 would do (docs/sensor.md §8).

Synthetic RCCB mosaics (the cell R C / C B, a clear site reading C = R + G + B as in photosite's
box basis) through the library's demosaic (`ps.demosaic(m, "RCCB", method, backend="cpu")`),
every method:

  noise  flat patches, 16 frames of 256 x 256 with independent noise: Poisson shot noise at
         1 DN per electron plus Gaussian read noise of 5 DN on every sample. "dark": R = G = B = 0;
         "red": a saturated red, R = 1000 DN, G = B = 0 (so C = 1000). The true G is 0 in both.
         Printed: the fraction of negative G, the mean G with its standard error (the spread of
         the 16 frame means / 4: the frames are independent, the pixels of one frame are not), and
         the mean of max(G, 0), what a consumer would measure had G been clipped at 0.
  edge   a hard-edged white disc (R = G = B = 1200 DN inside, 40 outside, radius 8 px; nothing
         clipped, no noise): the pixels with negative G and the most negative G; the same disc on
         an RGGB mosaic for comparison (min G there).
  clip   the same disc at R = G = B = 12000 with every sample clipped at 4000 DN and the clip
         handling on (white_level = 4000: pixels whose 3x3 window holds a clipped sample read
         4000 / 3 on all three): negative G outside that window; the same disc unclipped.

Usage: PYTHONPATH=build/python /usr/bin/python3 scripts/rccb_negative_g.py
"""
import numpy as np

import photosite as ps

METHODS = ["bilinear", "malvar", "hamilton-adams", "lmmse", "mlri"]


def mosaic(R, G, B, pattern="RCCB"):
    """Each site's own filter: RCCB R C / C B (C = R + G + B), or RGGB R G / G B."""
    m = np.empty(R.shape, np.float64)
    C = R + G + B if pattern == "RCCB" else G
    m[0::2, 0::2] = R[0::2, 0::2]
    m[0::2, 1::2] = C[0::2, 1::2]
    m[1::2, 0::2] = C[1::2, 0::2]
    m[1::2, 1::2] = B[1::2, 1::2]
    return m


def noisy(m, rng, read_dn=5.0):
    return (rng.poisson(np.maximum(m, 0)) + rng.normal(0.0, read_dn, m.shape)).astype(np.float32)


def main():
    n, frames = 256, 16
    zero = np.zeros((n, n))
    print("noise: case,method,negative_fraction,mean_G_dn,se_dn,mean_of_G_clipped_at_0_dn")
    for case, (R, G, B) in {"dark": (zero, zero, zero), "red": (zero + 1000, zero, zero)}.items():
        for method in METHODS:
            rng = np.random.default_rng(1)
            means, neg, clipped = [], [], []
            for _ in range(frames):
                g = ps.demosaic(noisy(mosaic(R, G, B), rng), "RCCB", method, backend="cpu")[8:-8, 8:-8, 1]
                means.append(g.mean())
                neg.append((g < 0).mean())
                clipped.append(np.maximum(g, 0).mean())
            se = np.std(means, ddof=1) / np.sqrt(frames)
            print(f"{case},{method},{np.mean(neg):.3f},{np.mean(means):.3f},{se:.3f},{np.mean(clipped):.2f}")

    yy, xx = np.mgrid[0:96, 0:128].astype(np.float64)
    inside = (xx - 64.3) ** 2 + (yy - 47.6) ** 2 <= 64
    print("edge: method,pixels_G_below_0,min_G_dn,rggb_min_G_dn")
    for method in METHODS:
        L = np.where(inside, 1200.0, 40.0)
        g = ps.demosaic(mosaic(L, L, L).astype(np.float32), "RCCB", method, backend="cpu")[..., 1]
        gb = ps.demosaic(mosaic(L, L, L, "RGGB").astype(np.float32), "RGGB", method, backend="cpu")[..., 1]
        print(f"{method},{(g < 0).sum()},{g.min():.1f},{gb.min():.1f}")
    print("clip: method,clipped_samples,pixels_G_below_0_outside_the_neutral_window,min_G_there_dn,"
          "unclipped_pixels_G_below_0,unclipped_min_G_dn")
    clip = 4000.0
    for method in METHODS:
        L = np.where(inside, 12000.0, 40.0)
        full = mosaic(L, L, L)
        m = np.minimum(full, clip).astype(np.float32)
        hit = m >= clip
        near = np.zeros_like(hit)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                near |= np.roll(np.roll(hit, dy, 0), dx, 1)
        g = ps.demosaic(m, "RCCB", method, backend="cpu", white_level=clip)[..., 1][~near]
        gu = ps.demosaic(full.astype(np.float32), "RCCB", method, backend="cpu")[..., 1]
        print(f"{method},{hit.sum()},{(g < 0).sum()},{g.min():.1f},{(gu < 0).sum()},{gu.min():.1f}")


if __name__ == "__main__":
    main()
