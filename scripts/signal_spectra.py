#!/usr/bin/python3
"""Traffic-signal and rear-lamp LED spectra: chromaticity, dominant wavelength, the signal-colour regions,
and what the bundled cameras record of them against photosite's old box colours (issue 14).

Run:  /usr/bin/python3 scripts/signal_spectra.py

The model (sensor/spectrum.cpp spectrum::lamp_spd, the same numbers): a single-colour LED's relative
spectral power is a plain Gaussian of its peak wavelength and its spectral half-width (the full width at
half maximum, FWHM, which the LED datasheets give as "spectral halfwidth" Δλ1/2):
    S(λ) = exp(-4 ln2 (λ - λ_p)² / FWHM²).
Not Ohno's (2005) [g + 2 g^5]/3, which is peakier for the same width parameter; a real AlInGaP or InGaN
line is also a little asymmetric (a longer tail on the long-wavelength side). Neither matters to the
camera's raw colour at the level the LEDs' own spread does (the ±50 % half-width rows below).

Each Gaussian's peak is solved so that its dominant wavelength is the data sheet's: the dominant
wavelength is what fixes the colour (the data sheets bin by it and the signal standards bound the
chromaticity), while the peak-to-dominant offset depends on the line's shape, which the symmetric
Gaussian does not have (a Gaussian at the red data sheet's 635-nm peak has a 632-nm dominant
wavelength, not 626). The data sheets' peaks are printed beside the solved ones.

Numbers and their sources ("verify before you cite": [U] = not read, a typical value):
  Red (signals and rear lamps), AlInGaP: peak 635 nm, dominant 626 nm: Broadcom HSMx-A46x (PLCC-4
    AlInGaP/InGaN) data sheet, Table 3 "Optical Characteristics", HSMC-A46x red: λpeak 635, λd 626 typ.
    (read: 38.142.81.21:8001/manual/broadcom/hsma-a461-x83m1/datasheet-english/page-3.html). The
    traffic-signal lamps HLMP-EGxx/ELxx ("Colors: 590nm Amber, 626nm Red", applications "Traffic
    signals", read: dtsheet.com/doc/1202317/avago-hlmp-egxx) have the same dominant wavelengths.
    Rear lamps take the same red LED: a photosite choice (no rear-lamp LED data sheet read); it is
    checked against ECE R48's red below.
  Amber / yellow signal, AlInGaP: peak 592 nm, dominant 590 nm: the same Table 3, HSMA-A46x amber;
    HLMP-ELxx "590nm Amber" (both read).
  Green (blue-green) signal, InGaN: dominant 505 nm: Avago HLMP-Cxxx (HLMP-CM30 ...) data sheet: "The
    505 nm typical dominant wavelength matches international specifications for green traffic
    signals" (read: pdf.datasheet.directory/d7d13e49/avagotech.com/HLMP-CM30-RSBDD.txt); its peak
    wavelength was not read.
  Spectral half-widths (FWHM) [U]: AlInGaP red and amber 17 nm, InGaN cyan 30 nm, the typical
    "spectral halfwidth" of such data sheets as remembered; the tables holding them could not be read
    here. The rows with FWHM x0.5 and x1.5 show what the camera colour does if they are wrong.

Colour regions (CIE 1931 x, y):
  ITE VTCSH Part 2 (LED vehicle signal modules, 1998) as tabulated by the LRC's "LED traffic signal
    comparison" (read: www.lrc.rpi.edu/programs/transportation/LED/LEDTrafficSignalComparison.asp):
    red y <= 0.308, y >= 0.998 - x; yellow 0.411 <= y <= 0.452, y >= 0.995 - x; green
    y >= 0.506 - 0.519 x, y >= 0.150 + 1.068 x, y <= 0.730 - x.
  EN 12368 (the draft European standard of January 1998, the same LRC table): red 0.290 <= y <= 0.320,
    y >= 0.980 - x; yellow y >= 0.387, y >= 0.980 - x, y <= 0.727 x + 0.054; green y <= 0.726 - 0.726 x,
    x <= 0.625 y - 0.041, y >= 0.400. (The copy read had lost its minus signs; they are restored from
    the regions' geometry, and the inequalities' directions from which side of each boundary the
    colour lies: both are this script's reading, not the standard's text.)
  ECE R48 §2.29 red (read: lexaris.io, UN/ECE Regulation No 48 as published in the OJ): yellow
    boundary y <= 0.335, purple boundary y >= 0.980 - x (corners (0.645, 0.335) ... (0.721, 0.259)).
Chromaticity with the tabulated CIE 1931 2-degree colour-matching functions (below), the spectral locus
from the same table; the dominant wavelength from the equal-energy point E (1/3, 1/3),
as LED data sheets quote it.
"""
import math
import pathlib
import tomllib

from lamp_spectra import BANDS, WL

# CIE 1931 2-degree colour-matching functions, 380-780 nm every 5 nm (CIE 015:2018; read from
# colour-science/colour colour/colorimetry/datasets/cmfs.py, commit 9d743142e, the 1-nm table's 5-nm rows).
XBAR = [0.001368, 0.002236, 0.004243, 0.00765, 0.01431, 0.02319, 0.04351, 0.07763, 0.13438, 0.21477, 0.2839, 0.3285, 0.34828, 0.34806, 0.3362, 0.3187, 0.2908, 0.2511, 0.19536, 0.1421, 0.09564, 0.05795001, 0.03201, 0.0147, 0.0049, 0.0024, 0.0093, 0.0291, 0.06327, 0.1096, 0.1655, 0.2257499, 0.2904, 0.3597, 0.4334499, 0.5120501, 0.5945, 0.6784, 0.7621, 0.8425, 0.9163, 0.9786, 1.0263, 1.0567, 1.0622, 1.0456, 1.0026, 0.9384, 0.8544499, 0.7514, 0.6424, 0.5419, 0.4479, 0.3608, 0.2835, 0.2187, 0.1649, 0.1212, 0.0874, 0.0636, 0.04677, 0.0329, 0.0227, 0.01584, 0.01135916, 0.008110916, 0.005790346, 0.004109457, 0.002899327, 0.00204919, 0.001439971, 0.0009999493, 0.0006900786, 0.0004760213, 0.0003323011, 0.0002348261, 0.0001661505, 0.000117413, 8.307527e-05, 5.870652e-05, 4.150994e-05]
YBAR = [3.9e-05, 6.4e-05, 0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684, 0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, 0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082, 0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949, 0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484, 0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 8.48e-05, 6e-05, 4.24e-05, 3e-05, 2.12e-05, 1.499e-05]
ZBAR = [0.006450001, 0.01054999, 0.02005001, 0.03621, 0.06785001, 0.1102, 0.2074, 0.3713, 0.6456, 1.0390501, 1.3856, 1.62296, 1.74706, 1.7826, 1.77211, 1.7441, 1.6692, 1.5281, 1.28764, 1.0419, 0.8129501, 0.6162, 0.46518, 0.3533, 0.272, 0.2123, 0.1582, 0.1117, 0.07824999, 0.05725001, 0.04216, 0.02984, 0.0203, 0.0134, 0.008749999, 0.005749999, 0.0039, 0.002749999, 0.0021, 0.0018, 0.001650001, 0.0014, 0.0011, 0.001, 0.0008, 0.0006, 0.00034, 0.00024, 0.00019, 0.0001, 4.999999e-05, 3e-05, 2e-05, 1e-05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]

STEP = 0.5
LO, HI = 380.0, 780.0

# name: (dominant nm, FWHM nm, the data sheet's peak nm or None): the Gaussian's peak is solved so that
# its dominant wavelength is the data sheet's (green_peak below); sensor/spectrum.h kSignalLeds holds the result.
LEDS = {
    "red": (626.0, 17.0, 635.0),
    "amber": (590.0, 17.0, 592.0),
    "green": (505.0, 30.0, None),
}
OLD_BOXES = {"red": (1.0, 0.03, 0.0), "amber": (1.0, 0.45, 0.0), "green": (0.0, 1.0, 0.6)}  # scene/lights.cpp


def gauss(peak, fwhm):
    return lambda l: math.exp(-4.0 * math.log(2.0) * (l - peak) ** 2 / fwhm ** 2)


def grid(lo=LO, hi=HI):
    n = int(round((hi - lo) / STEP))
    return [lo + (i + 0.5) * STEP for i in range(n)]


def xy_of(f):
    """CIE 1931 (x, y) of a spectrum: sums on the tables' 5-nm grid (a Gaussian of FWHM >= 8.5 nm is
    resolved by it: the sum's aliasing error ~exp(-2 pi^2 sigma^2 / (5 nm)^2) < 1e-7 for sigma >= 3.6 nm)."""
    X = sum(f(l) * v for l, v in zip(WL, XBAR))
    Y = sum(f(l) * v for l, v in zip(WL, YBAR))
    Z = sum(f(l) * v for l, v in zip(WL, ZBAR))
    t = X + Y + Z
    return X / t, Y / t


def locus(l):
    """The spectral locus at l nm, the tables linear between their 5-nm rows."""
    i = min(int((l - 380) // 5), len(WL) - 2)
    f = (l - WL[i]) / 5.0
    X, Y, Z = ((t[i] * (1 - f) + t[i + 1] * f) for t in (XBAR, YBAR, ZBAR))
    return X / (X + Y + Z), Y / (X + Y + Z)


def dominant_nm(x, y, wx=1 / 3, wy=1 / 3):
    """The spectral wavelength on the ray from the white point through (x, y) (1-nm search, then bisection)."""
    a = math.atan2(y - wy, x - wx)

    def d(l):
        lx, ly = locus(l)
        e = math.atan2(ly - wy, lx - wx) - a
        return (e + math.pi) % (2 * math.pi) - math.pi

    # the bracket (1 nm) where the angle difference changes sign on the near side of the locus
    brackets = [l for l in range(460, 700) if (d(l) > 0) != (d(l + 1) > 0) and abs(d(l)) < 0.5]
    lo, hi = float(brackets[0]), float(brackets[0] + 1)
    for _ in range(40):
        m = 0.5 * (lo + hi)
        if (d(lo) > 0) == (d(m) > 0):
            lo = m
        else:
            hi = m
    return 0.5 * (lo + hi)


def peak_for(dominant, fwhm):
    """The Gaussian's peak whose dominant wavelength is `dominant` (bisection; it rises with the peak)."""
    lo, hi = dominant - 15.0, dominant + 15.0
    for _ in range(50):
        m = 0.5 * (lo + hi)
        if dominant_nm(*xy_of(gauss(m, fwhm))) < dominant:
            lo = m
        else:
            hi = m
    return 0.5 * (lo + hi)


REGIONS = {
    "ITE VTCSH red": lambda x, y: y <= 0.308 and y >= 0.998 - x,
    "ITE VTCSH yellow": lambda x, y: 0.411 <= y <= 0.452 and y >= 0.995 - x,
    "ITE VTCSH green": lambda x, y: y >= 0.506 - 0.519 * x and y >= 0.150 + 1.068 * x and y <= 0.730 - x,
    "EN 12368 red": lambda x, y: 0.290 <= y <= 0.320 and y >= 0.980 - x,
    "EN 12368 yellow": lambda x, y: y >= 0.387 and y >= 0.980 - x and y <= 0.727 * x + 0.054,
    "EN 12368 green": lambda x, y: y <= 0.726 - 0.726 * x and x <= 0.625 * y - 0.041 and y >= 0.400,
    "ECE R48 red": lambda x, y: y <= 0.335 and y >= 0.980 - x,
}
CHECKS = {"red": ("ITE VTCSH red", "EN 12368 red", "ECE R48 red"),
          "amber": ("ITE VTCSH yellow", "EN 12368 yellow"),
          "green": ("ITE VTCSH green", "EN 12368 green")}


def camera_qe(name):
    root = pathlib.Path(__file__).resolve().parent.parent
    q = tomllib.loads((root / "presets" / "cameras" / (name + ".toml")).read_text())["qe"]
    wl = q["wavelength_nm"]
    chans = [c for c in ("r", "g", "b", "c") if c in q]

    def qe(c, l):  # linear between the table's points, 0 outside (QeTable::at)
        if l < wl[0] or l > wl[-1]:
            return 0.0
        for i in range(len(wl) - 1):
            if wl[i] <= l <= wl[i + 1]:
                f = (l - wl[i]) / (wl[i + 1] - wl[i])
                return q[c][i] * (1 - f) + q[c][i + 1] * f
        return q[c][-1]
    return chans, qe


def raw_spd(chans, qe, f):
    """Electrons per filter colour (relative: photons ∝ λ), the spectrum itself, 0.5-nm midpoints."""
    return {c: sum(f(l) * qe(c, l) * l for l in grid()) for c in chans}


def raw_boxes(chans, qe, w):
    """The same through the box basis: Σ_k w_k · mean over box k of QE_c·λ (the sensor model's)."""
    out = {}
    for c in chans:
        s = 0.0
        for k, band in zip(w, "RGB"):
            lo, hi = BANDS[band]
            s += k * sum(qe(c, l) * l for l in grid(lo, hi)) * STEP / (hi - lo)
        out[c] = s
    return out


def main():
    leds = {}
    print("The Gaussians' peaks (sensor/spectrum.h kSignalLeds), for the data sheets' dominant wavelengths:")
    for name, (dom, fwhm, sheet_peak) in LEDS.items():
        leds[name] = (peak_for(dom, fwhm), fwhm)
        print("  %-6s dominant %.0f nm, FWHM %.0f nm: peak %.2f nm (data sheet's peak: %s)"
              % (name, dom, fwhm, leds[name][0], "%.0f nm" % sheet_peak if sheet_peak else "not read"))
    print("\nChromaticity (CIE 1931 2-degree, tabulated), dominant wavelength (from E), regions:")
    for name, (p, w) in leds.items():
        for scale in (1.0, 0.5, 1.5):
            x, y = xy_of(gauss(p, w * scale))
            inside = ", ".join("%s %s" % (r, "in" if REGIONS[r](x, y) else "OUT") for r in CHECKS[name])
            print("  %-6s peak %.2f FWHM %4.1f: x %.4f y %.4f  dominant %.1f nm  %s"
                  % (name, p, w * scale, x, y, dominant_nm(x, y), inside))
    ox = {k: xy_of_boxes(v) for k, v in OLD_BOXES.items()}
    for k, (x, y) in ox.items():
        inside = ", ".join("%s %s" % (r, "in" if REGIONS[r](x, y) else "OUT") for r in CHECKS[k])
        print("  %-6s old box guess %s (scene/lights.cpp): x %.4f y %.4f  dominant %.1f nm  %s"
              % (k, OLD_BOXES[k], x, y, dominant_nm(x, y), inside))

    print("\nRaw camera colour (G/R, B/R of the filter colours' electrons): the LED spectrum, its camera"
          "\nmetamer (= the spectrum by construction), the old boxes; for RCCC C/R:")
    for cam in ("onsemi-ar0331", "sony-icx267-flea2", "sony-imx174", "sony-imx490", "sony-a7s2", "onsemi-ar0132at-rccc"):
        chans, qe = camera_qe(cam)
        for name, (p, w) in leds.items():
            e = raw_spd(chans, qe, gauss(p, w))
            b = raw_boxes(chans, qe, OLD_BOXES[name])
            if "g" in chans:
                print("  %-21s %-6s spectrum G/R %8.4f B/R %8.4f   old boxes G/R %8.4f B/R %8.4f"
                      % (cam, name, e["g"] / e["r"], e["b"] / e["r"], b["g"] / b["r"], b["b"] / b["r"]))
            else:
                print("  %-21s %-6s spectrum C/R %8.4f   old boxes C/R %8.4f" % (cam, name, e["c"] / e["r"], b["c"] / b["r"]))
    chans, qe = camera_qe("onsemi-ar0331")
    print("\nAR0331, half-width sensitivity (the [U] FWHMs x0.5 and x1.5):")
    for name, (p, w) in leds.items():
        row = []
        for scale in (0.5, 1.0, 1.5):
            e = raw_spd(chans, qe, gauss(p, w * scale))
            row.append("FWHM %4.1f: G/R %.4f B/R %.4f" % (w * scale, e["g"] / e["r"], e["b"] / e["r"]))
        print("  %-6s %s" % (name, "   ".join(row)))


def xy_of_boxes(w):
    """(x, y) of box radiances w (flat within each 100-nm box; 5-nm rows, a box edge's row halved)."""
    def box(t, b):
        lo, hi = BANDS[b]
        return sum(v * (0.5 if l in (lo, hi) else 1.0) for l, v in zip(WL, t) if lo <= l <= hi)
    X, Y, Z = (sum(k * box(t, b) for k, b in zip(w, "RGB")) for t in (XBAR, YBAR, ZBAR))
    return X / (X + Y + Z), Y / (X + Y + Z)


if __name__ == "__main__":
    main()
