#!/usr/bin/python3
"""False colour at hard neutral edges, RCCB against RGGB, every demosaic method (docs/demosaic.md,
"RCCB").

Three neutral scenes (R = G = B everywhere), 256 x 256, a white of 1,200 DN on a black of 40 DN:
a disc of radius 40 px, a vertical bar 9 px wide, and an edge slanted 5 degrees from vertical;
each pixel the area mean of an 8 x 8 supersampling (the sensor integrates over its pixel), so the
edges are as sharp as a pixel. No noise, nothing clipped. Each scene is mosaicked as a sensor
samples it (RGGB: R G / G B; RCCB: R C / C B with C = R + G + B, photosite's box basis, docs/sensor.md
section 8) and demosaiced by the library (`ps.demosaic(m, pattern, method, backend="cpu")`).
The false colour of a pixel is max(|R - G|, |B - G|) / 1,200 (the scene has none: every
deviation is the demosaic's); printed per scene, pattern and method: its maximum and its mean
over the edge band (pixels within 3 px of an edge, 8 px of border left out) and how many band
pixels exceed 5 %. The last rows (method bilinear-colour-difference) are a numpy prototype, not
in the library: C (RGGB: G) at the red and blue sites as the 4-neighbour mean, then R - kC and
B - kC (k = 1/3 on RCCB, 1 on RGGB) bilinear from their own sites, and G = C - R - B on RCCB:
whether interpolating colour differences instead of the planes lowers RCCB's fringes.
Then, per scene and library method, how far RCCB's colour errors (R - G, B - G) lie from
(2 dR + dB, dR + 2 dB), (dR, dB) = RGGB's (R - G, B - G) at the same pixel, and how far its R and
B lie from RGGB's (DN; 0 up to float rounding: on a neutral scene the clear samples are 3x the
green ones, and RCCB's output is RGGB's with G = 3 G_hat - R - B).

Usage: PYTHONPATH=build/python /usr/bin/python3 scripts/rccb_edges.py
"""
import numpy as np
import photosite as ps

METHODS = ["bilinear", "malvar", "hamilton-adams", "lmmse", "mlri"]
N, SS, HI, LO, BORDER, BAND = 256, 8, 1200.0, 40.0, 8, 3


def coverage(inside):
    """Area share of each pixel inside the shape (8 x 8 samples per pixel)."""
    o = (np.arange(SS) + 0.5) / SS
    yy, xx = np.meshgrid(np.arange(N), np.arange(N), indexing="ij")
    acc = np.zeros((N, N))
    for dy in o:
        for dx in o:
            acc += inside(xx + dx, yy + dy)
    return acc / SS ** 2


def scenes():
    c = N / 2
    t = np.tan(np.radians(5))
    return {
        "disc": coverage(lambda x, y: (x - c) ** 2 + (y - c) ** 2 <= 40 ** 2),
        "bar": coverage(lambda x, y: np.abs(x - c) <= 4.5),
        "slanted": coverage(lambda x, y: x - c >= (y - c) * t),
    }


def mosaic(L, pattern):
    m = np.empty(L.shape, np.float32)
    C = 3 * L if pattern == "RCCB" else L
    m[0::2, 0::2] = L[0::2, 0::2]
    m[0::2, 1::2] = C[0::2, 1::2]
    m[1::2, 0::2] = C[1::2, 0::2]
    m[1::2, 1::2] = L[1::2, 1::2]
    return m


def band(a):
    """Pixels within BAND px of a pixel whose coverage is neither 0 nor 1 or that differs from a
    neighbour (the edge), the border left out."""
    e = np.zeros(a.shape, bool)
    e |= (a > 0) & (a < 1)
    e[:, 1:] |= a[:, 1:] != a[:, :-1]
    e[1:, :] |= a[1:, :] != a[:-1, :]
    b = e.copy()
    for _ in range(BAND):
        g = b.copy()
        g[1:, :] |= b[:-1, :]
        g[:-1, :] |= b[1:, :]
        g[:, 1:] |= b[:, :-1]
        g[:, :-1] |= b[:, 1:]
        b = g
    b[:BORDER, :] = b[-BORDER:, :] = b[:, :BORDER] = b[:, -BORDER:] = False
    return b


def conv3(a, k):
    """3 x 3 correlation with reflect-101 borders (the library's)."""
    p = np.pad(a, 1, mode="reflect")
    return sum(k[i, j] * p[i:i + a.shape[0], j:j + a.shape[1]] for i in range(3) for j in range(3))


def colour_difference_bilinear(m, pattern):
    r = np.zeros(m.shape, bool)
    r[0::2, 0::2] = True
    b = np.zeros(m.shape, bool)
    b[1::2, 1::2] = True
    c = ~(r | b)
    k = 1.0 / 3.0 if pattern == "RCCB" else 1.0
    k4 = np.array([[0, 1, 0], [1, 4, 1], [0, 1, 0]], float)
    k9 = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], float)

    def interp(v, mask, kern):
        return conv3(v * mask, kern) / conv3(mask.astype(float), kern)

    C = np.where(c, m, interp(m, c, k4))
    R = k * C + interp(m - k * C, r, k9)
    B = k * C + interp(m - k * C, b, k9)
    G = C - R - B if pattern == "RCCB" else C
    return np.stack([R, G, B], -1)


def main():
    print("scene,pattern,method,max_false_colour,mean_false_colour_band,band_pixels_over_5pct,band_pixels")
    for name, a in scenes().items():
        L = LO + (HI - LO) * a
        bd = band(a)
        for pattern in ["RGGB", "RCCB"]:
            for method in METHODS + ["bilinear-colour-difference"]:
                m = mosaic(L, pattern)
                if method in METHODS:
                    y = ps.demosaic(m, pattern, method, backend="cpu").astype(np.float64)
                else:
                    y = colour_difference_bilinear(m.astype(np.float64), pattern)
                fc = np.maximum(np.abs(y[..., 0] - y[..., 1]), np.abs(y[..., 2] - y[..., 1])) / HI
                inner = np.zeros(bd.shape, bool)
                inner[BORDER:-BORDER, BORDER:-BORDER] = True
                print(f"{name},{pattern},{method},{fc[inner].max():.4f},{fc[bd].mean():.4f},"
                      f"{int((fc[bd] > 0.05).sum())},{int(bd.sum())}")
    print("scene,method,max_dn_from_2dR+dB_dR+2dB,max_dn_R_B_from_rggb")
    for name, a in scenes().items():
        L = LO + (HI - LO) * a
        for method in METHODS:
            y, z = (ps.demosaic(mosaic(L, p), p, method, backend="cpu").astype(np.float64) for p in ["RGGB", "RCCB"])
            dR, dB = y[..., 0] - y[..., 1], y[..., 2] - y[..., 1]
            off = max(np.abs(z[..., 0] - z[..., 1] - (2 * dR + dB)).max(), np.abs(z[..., 2] - z[..., 1] - (dR + 2 * dB)).max())
            rb = max(np.abs(z[..., 0] - y[..., 0]).max(), np.abs(z[..., 2] - y[..., 2]).max())
            print(f"{name},{method},{off:.3g},{rb:.3g}")


if __name__ == "__main__":
    main()
