#!/usr/bin/python3
"""The traffic signals of two `photosite night` runs of one frame (before and after a change of the
lamps' colours): per signal colour, the lens pixels' and their glare halo's mean preview sRGB and
HSV hue, the mean electrons' G/R and B/R (a GRBG sensor such as the AR0331), and the lights layer's.

Run:  /usr/bin/python3 scripts/signal_colours.py OLD.exr NEW.exr OLD_PREVIEW.png NEW_PREVIEW.png

The lenses are the traffic-light pixels (Cityscapes labelId 19) whose lights the change altered,
classed by the old colour; a halo is 2..6 px around its colour's lenses, off every lens. Channels
are read through oiiotool's FITS writer (no Python OpenImageIO here)."""
import colorsys
import os
import subprocess
import sys
import tempfile

import numpy as np

FLIP = True  # FITS rows are bottom-up (checked: the ego vehicle, label 1, lands in the last rows)


def read_channels(path, ch=None, tmp=None):
    """The image's channels as float (H, W, C), through oiiotool's FITS writer (big-endian float32,
    2880-byte header blocks; OIIO writes the rows bottom-up as FITS does)."""
    tmp = tmp or os.path.join(tempfile.gettempdir(), "signal_colours_%d.fits" % os.getpid())
    cmd = ["oiiotool", path] + (["--ch", ch] if ch else []) + ["-d", "float", "-o", tmp]
    subprocess.run(cmd, check=True, capture_output=True)
    b = open(tmp, "rb").read()
    hdr = {}
    off = 0
    while True:
        card = b[off:off + 80].decode("ascii"); off += 80
        if card.startswith("END"):
            break
        if "=" in card[:10]:
            hdr[card[:8].strip()] = card[10:].split("/")[0].strip()
    off = (off + 2879) // 2880 * 2880
    n = int(hdr["NAXIS"])
    dims = [int(hdr["NAXIS%d" % (i + 1)]) for i in range(n)]
    if n == 2:
        dims = [1] + dims
    c, w, h = dims
    a = np.frombuffer(b[off:off + 4 * c * w * h], dtype=">f4").reshape(h, w, c).astype(np.float64)
    os.remove(tmp)
    return a[::-1] if FLIP else a

def main(old_exr, new_exr, old_png, new_png):
    lab = np.round(read_channels(old_exr, "labels.Y")[:, :, 0] * 4294967295.0)
    lo = read_channels(old_exr, "lights.R,lights.G,lights.B")
    ln = read_channels(new_exr, "lights.R,lights.G,lights.B")
    # the signal lenses: traffic-light pixels whose lights the change altered, by the old colour
    R, G, B = lo[:, :, 0], lo[:, :, 1], lo[:, :, 2]
    ch = (lab == 19) & (np.abs(lo - ln).sum(2) > 0)
    cls = {"red": ch & (R > 0) & (G < 0.2 * R), "amber": ch & (R > 0) & (G >= 0.2 * R) & (G <= R),
           "green": ch & (G > R)}
    po, pn = read_channels(old_png), read_channels(new_png)
    eo, en = (read_channels(x, "electrons.Y")[:, :, 0] * 4294967295.0 for x in (old_exr, new_exr))
    H, W = lab.shape
    yy, xx = np.mgrid[0:H, 0:W]
    cfa = {"G": ((xx + yy) % 2 == 0), "R": (xx % 2 == 1) & (yy % 2 == 0), "B": (xx % 2 == 0) & (yy % 2 == 1)}
    def dilate(m, r):
        out = m.copy()
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                out |= np.roll(np.roll(m, dy, 0), dx, 1)
        return out
    # and each colour's halo: 2..6 px around its lenses, off every lens (the lens glare's colour,
    # where the lenses themselves clip)
    anyl = cls["red"] | cls["amber"] | cls["green"]
    for k in list(cls):
        cls[k + " halo"] = dilate(cls[k], 6) & ~dilate(anyl, 1)
    for name, m in cls.items():
        n = int(m.sum())
        if n == 0:
            print("  %-11s 0 px" % name); continue
        row = []
        for tag, p, e, l in (("old", po, eo, lo), ("new", pn, en, ln)):
            s = p[m].mean(0)
            h = colorsys.rgb_to_hsv(*s)[0] * 360
            # raw colour of the signal and a 2-px ring? just the lens pixels
            r = {c: e[m & k].mean() if (m & k).any() else float("nan") for c, k in cfa.items()}
            lr = l[m].mean(0)
            row.append("%s: sRGB %s hue %5.1f  raw e G/R %.3f B/R %.3f (R %.0f e)  lights G/R %.4f B/R %.4f"
                       % (tag, "(%3d,%3d,%3d)" % tuple(np.round(255 * s)), h, r["G"] / r["R"], r["B"] / r["R"], r["R"], lr[1] / lr[0], lr[2] / lr[0]))
        print("  %-11s %5d px | %s\n  %-11s          | %s" % (name, n, row[0], "", row[1]))

if __name__ == "__main__":
    main(*sys.argv[1:5])
