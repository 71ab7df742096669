#!/usr/bin/python3
"""Modelled spectral QE curves for camera presets whose absolute curves are not published.

Shape: silicon photodiode response (a broad hump peaking near 550-600 nm) times CFA dye
transmissions (Gaussian-like B and G passbands, a logistic R edge) times a 650 nm IR-cut
filter edge. Each curve is scaled so that the green (or clear) peak equals the given peak QE.
Usage: model_qe.py PEAK_QE [b_center g_center r_edge]   -> TOML [qe] table on stdout.
"""
import math, sys

peak = float(sys.argv[1])
bc, gc, re = (float(x) for x in sys.argv[2:5]) if len(sys.argv) > 4 else (460.0, 535.0, 588.0)
wl = list(range(400, 701, 10))

def silicon(l):   # relative internal QE of a front/back-side illuminated CMOS pixel
    return math.exp(-0.5 * ((l - 560.0) / 130.0) ** 2)
def ircut(l):     # IR-cut filter edge at 650 nm
    return 1.0 / (1.0 + math.exp((l - 655.0) / 12.0))
def blue(l):  return 0.05 + 0.95 * math.exp(-0.5 * ((l - bc) / 32.0) ** 2)
def green(l): return 0.04 + 0.96 * math.exp(-0.5 * ((l - gc) / 38.0) ** 2)
def red(l):   return 0.03 + 0.97 / (1.0 + math.exp(-(l - re) / 11.0))
def clear(l): return 1.0

curves = {k: [silicon(l) * ircut(l) * f(l) for l in wl]
          for k, f in (("r", red), ("g", green), ("b", blue), ("c", clear))}
scale = peak / max(curves["g"])
print("wavelength_nm = [" + ", ".join(str(l) for l in wl) + "]")
for k in ("r", "g", "b", "c"):
    print(f"{k} = [" + ", ".join(f"{min(1.0, v * scale):.3f}" for v in curves[k]) + "]")
