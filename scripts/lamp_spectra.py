#!/usr/bin/python3
"""Street-lamp spectra in photosite's box basis: the numbers in sensor/spectrum.cpp (hp1_band_radiance).

Run:  /usr/bin/python3 scripts/lamp_spectra.py

photosite's spectral model (include/photosite/sensor/spectrum.h) keeps a spectrum as its integrals
over three 100-nm boxes, R 600-700, G 500-600, B 400-500 nm, and its luminance as dot(K, rgb) with
K_k = 683 lm/W times the mean of V(lambda) over box k. This script reads a lamp's tabulated
relative spectral power distribution (SPD), integrates it over the boxes and prints:

  * the band integrals of CIE illuminant HP1 (standard high-pressure sodium), the constants that
    sensor/spectrum.cpp holds (in the table's relative units: only their ratios and the luminance
    they carry matter, spectrum::hp1_rgb scales them to the luminance asked);
  * the luminous efficacy of radiation of HP1 over 380-780 nm with the tabulated CIE 1931 V(lambda),
    to check the data against /work/shared/reference/night-photometry.md §0 (HP1: 395 lm/W);
  * the photopic luminance of the box radiances over photosite's box luminance dot(K, rgb): how far
    the box basis's luminance is from V(lambda) on the real spectrum (for HP1 and for the Planck
    proxy of an LED);
  * the band ratios of CIE LED-B3 (a phosphor-converted white LED of about 4000 K) against those of
    a Planck radiator at 4000 K, the proxy photosite keeps for LED street lamps in a scene made
    without a camera;
  * the chromaticities of HP1 and LED-B1..B5 against CIE 015:2018's published ones and LED-B1..B5's
    luminous efficacies against night-photometry.md §0's (checks of the data read, the tables that
    include/photosite/sensor/spectrum.h holds as kLedBSpd5nm), and the box radiances with HP1's CIE
    XYZ (a colorimetric metamer);
  * what the two bundled dataset cameras (onsemi-ar0331, sony-icx267-flea2: their presets' QE
    tables) see: the raw G/R and B/R of each lamp's SPD against those of its box radiances through
    the sensor model's box-averaged QE. For HP1 the box basis is far off (its sodium light at
    570-600 nm is averaged over the G box, where the R filter's QE is low): docs/night.md §7. The
    SPD's raw ratios are what the night chain's camera metamer (camera_metamer_rgb) gives a grey
    surface; the Planck rows are what an led street gave before the LED-B metamer (and still gives
    in a scene without a camera).

Integration: the SPDs are sampled every 5 nm; the band integral is the trapezoid rule on that
grid, i.e. each sample stands for the 5 nm around it and a sample on a band edge (400, 500, 600,
700 nm) is split half and half between the two bands. HP1's 500-nm sample (56.24) holds the sodium
lines at 497.9/498.3 nm, which lie in the B box: the script also prints the ratios with that
sample wholly in B, the reading's uncertainty from the table's 5-nm resolution.

Data (tabulated values, not code):
  HP1, LED-B1..B5: CIE 015:2018 Colorimetry, 4th edition (doi:10.25039/TR.015.2018), the illuminants
    representing high-pressure discharge lamps (HP1-HP5) and typical LED lamps (LED-B1..B5), 5 nm,
    380-780 nm; read from colour-science/colour, colour/colorimetry/datasets/illuminants/sds.py
    (commit 9d743142e, 2024; it cites CIE 015:2018 as Carter et al. 2018).
  V(lambda): CIE 1931 2-degree observer y-bar, 5 nm, 380-780 nm (CIE 015:2018 Table; read from
    colour-science/colour colour/colorimetry/datasets/cmfs.py, the same commit).
photosite's band efficacies use its own V(lambda) fit (Wyman, Sloan & Shirley 2013, as
sensor/spectrum.cpp), recomputed here the same way (0.5-nm midpoint rule).
"""
import math

WL = [380 + 5 * i for i in range(81)]  # nm

HP1 = [1.90, 2.20, 2.50, 2.70, 3.10, 4.30, 3.80, 4.20, 4.80, 5.19, 5.89, 7.39, 7.89, 5.69, 12.89, 6.69, 4.30,
       20.78, 12.99, 6.69, 1.40, 1.50, 3.20, 18.18, 56.24, 2.90, 2.10, 13.39, 2.10, 2.00, 2.20, 2.30, 2.60, 5.10,
       11.39, 15.48, 20.78, 55.64, 254.03, 56.14, 111.78, 297.98, 142.55, 334.84, 189.40, 117.78, 79.92, 108.09,
       46.85, 38.16, 32.47, 28.37, 25.37, 22.98, 20.38, 19.78, 17.78, 16.78, 19.18, 17.98, 13.69, 9.99, 8.19, 7.59,
       6.99, 6.79, 6.49, 6.39, 6.09, 5.99, 5.79, 5.79, 5.79, 5.79, 6.39, 5.99, 5.59, 31.97, 27.87, 5.89, 6.69]

LED_B1 = [0.00, 0.01, 0.01, 0.02, 0.04, 0.07, 0.15, 0.28, 0.53, 0.92, 1.54, 2.52, 4.16, 6.39, 7.89, 7.57, 6.25,
          5.16, 4.37, 3.84, 3.70, 3.88, 4.26, 4.79, 5.41, 6.05, 6.70, 7.34, 7.98, 8.64, 9.31, 10.02, 10.76, 11.53,
          12.38, 13.28, 14.23, 15.20, 16.20, 17.19, 18.14, 19.02, 19.78, 20.38, 20.80, 21.00, 20.97, 20.71, 20.23,
          19.56, 18.76, 17.82, 16.78, 15.66, 14.49, 13.31, 12.15, 11.02, 9.95, 8.93, 7.98, 7.10, 6.30, 5.57, 4.89,
          4.26, 3.72, 3.25, 2.83, 2.47, 2.15, 1.87, 1.63, 1.42, 1.25, 1.10, 0.97, 0.86, 0.76, 0.68, 0.61]
LED_B2 = [0.00, 0.00, 0.00, 0.01, 0.02, 0.05, 0.11, 0.24, 0.50, 0.96, 1.71, 2.82, 4.71, 7.87, 10.56, 10.24, 7.94,
          6.25, 5.23, 4.36, 4.00, 4.17, 4.59, 5.21, 5.96, 6.72, 7.44, 8.11, 8.74, 9.39, 10.06, 10.75, 11.49, 12.25,
          13.05, 13.86, 14.70, 15.50, 16.28, 17.00, 17.69, 18.31, 18.83, 19.24, 19.51, 19.59, 19.48, 19.19, 18.72,
          18.10, 17.34, 16.47, 15.51, 14.49, 13.42, 12.33, 11.26, 10.24, 9.25, 8.30, 7.42, 6.60, 5.85, 5.17, 4.55,
          3.99, 3.49, 3.04, 2.65, 2.31, 2.01, 1.75, 1.52, 1.32, 1.15, 1.00, 0.87, 0.76, 0.67, 0.59, 0.52]
LED_B3 = [0.00, 0.00, 0.01, 0.02, 0.05, 0.11, 0.25, 0.56, 1.20, 2.37, 4.24, 7.17, 12.11, 17.70, 18.87, 14.58, 9.90,
          7.53, 6.02, 5.11, 5.17, 5.82, 6.77, 7.88, 8.94, 9.82, 10.52, 11.06, 11.51, 11.93, 12.37, 12.83, 13.31,
          13.79, 14.26, 14.68, 15.08, 15.42, 15.72, 15.97, 16.18, 16.37, 16.50, 16.55, 16.50, 16.32, 16.00, 15.54,
          14.96, 14.27, 13.48, 12.62, 11.71, 10.78, 9.85, 8.93, 8.04, 7.20, 6.42, 5.69, 5.02, 4.42, 3.88, 3.39,
          2.95, 2.56, 2.22, 1.92, 1.65, 1.43, 1.23, 1.06, 0.91, 0.78, 0.68, 0.58, 0.50, 0.43, 0.37, 0.32, 0.28]
LED_B4 = [0.00, 0.00, 0.00, 0.01, 0.03, 0.08, 0.21, 0.54, 1.31, 2.75, 5.04, 8.31, 13.37, 20.61, 25.91, 24.12, 17.47,
          11.90, 8.62, 6.34, 4.89, 4.25, 4.19, 4.70, 5.77, 7.27, 8.94, 10.60, 12.11, 13.36, 14.30, 15.02, 15.54,
          15.90, 16.15, 16.33, 16.42, 16.44, 16.36, 16.20, 15.98, 15.70, 15.36, 14.93, 14.44, 13.86, 13.24, 12.57,
          11.84, 11.12, 10.38, 9.65, 8.91, 8.19, 7.51, 6.86, 6.21, 5.60, 5.05, 4.54, 4.05, 3.62, 3.23, 2.87, 2.53,
          2.24, 1.99, 1.76, 1.55, 1.37, 1.21, 1.07, 0.95, 0.85, 0.75, 0.67, 0.61, 0.55, 0.50, 0.45, 0.42]
LED_B5 = [0.00, 0.01, 0.01, 0.03, 0.07, 0.16, 0.35, 0.78, 1.67, 3.30, 5.94, 9.92, 16.15, 25.15, 32.34, 31.18, 23.46,
          16.39, 12.08, 9.08, 7.21, 6.48, 6.49, 7.05, 8.10, 9.45, 10.88, 12.22, 13.38, 14.29, 14.98, 15.48, 15.81,
          16.01, 16.10, 16.13, 16.10, 15.98, 15.77, 15.50, 15.15, 14.76, 14.31, 13.79, 13.22, 12.59, 11.91, 11.20,
          10.47, 9.73, 9.00, 8.27, 7.57, 6.90, 6.25, 5.65, 5.08, 4.55, 4.06, 3.61, 3.22, 2.86, 2.54, 2.26, 2.00,
          1.75, 1.54, 1.36, 1.20, 1.05, 0.93, 0.82, 0.72, 0.64, 0.56, 0.49, 0.44, 0.39, 0.35, 0.31, 0.27]
LED_B = [LED_B1, LED_B2, LED_B3, LED_B4, LED_B5]  # include/photosite/sensor/spectrum.h kLedBSpd5nm
LED_B_CCT = [2700, 3000, 4000, 5000, 6500]  # nominal CCTs, K
# CIE 015:2018's published chromaticities (x, y) of LED-B1..B5 (colour-science/colour
# colour/colorimetry/datasets/illuminants/chromaticity_coordinates.py, the same commit) and their
# luminous efficacies of radiation, /work/shared/reference/night-photometry.md §0.
LED_B_XY = [(0.4560, 0.4078), (0.4357, 0.4012), (0.3756, 0.3723), (0.3422, 0.3502), (0.3118, 0.3236)]
LED_B_LER = [312, 314, 317, 319, 305]

# CIE 1931 2° y-bar = V(lambda), 380-780 nm every 5 nm.
V = [0.000039, 0.000064, 0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684,
     0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, 0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073,
     0.503, 0.6082, 0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154,
     0.87, 0.8163, 0.757, 0.6949, 0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382, 0.107,
     0.0816, 0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091,
     0.001484, 0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 0.0000848, 0.00006,
     0.0000424, 0.00003, 0.0000212, 0.00001499]

KM = 683.0  # lm/W
BANDS = {"R": (600, 700), "G": (500, 600), "B": (400, 500)}  # photosite's order R, G, B


def band_integral(spd, lo, hi):
    """Trapezoid rule on the 5-nm grid over [lo, hi] (edge samples weighted 2.5 nm)."""
    s = 0.0
    for l, v in zip(WL, spd):
        if lo < l < hi:
            s += 5.0 * v
        elif l in (lo, hi):
            s += 2.5 * v
    return s


def bands(spd):
    return [band_integral(spd, *BANDS[k]) for k in "RGB"]


# photosite's V(lambda) fit and band efficacies (sensor/spectrum.cpp, band_luminous_efficacy_lm_per_W).
def _g(x, mu, s1, s2):
    t = (x - mu) / (s1 if x < mu else s2)
    return math.exp(-0.5 * t * t)


def y_bar_fit(l):
    return 0.821 * _g(l, 568.8, 46.9, 40.5) + 0.286 * _g(l, 530.9, 16.3, 31.1)


def midpoint(f, lo, hi, step=0.5):
    n = int(round((hi - lo) / step))
    return sum(f(lo + (i + 0.5) * step) for i in range(n)) * step


K_BAND = [KM * midpoint(y_bar_fit, *BANDS[k]) / 100.0 for k in "RGB"]


def box_luminance(rgb):
    return sum(k * c for k, c in zip(K_BAND, rgb))


def photopic(spd, lo=380, hi=780):
    """683 * integral of V * S over [lo, hi] (trapezoid on the 5-nm grid)."""
    return KM * band_integral([v * s for v, s in zip(V, spd)], lo, hi)


def planck(l_nm, T):
    h, c, k = 6.62607015e-34, 299792458.0, 1.380649e-23
    l = l_nm * 1e-9
    return 2 * h * c * c / l ** 5 / math.expm1(h * c / (l * k * T)) * 1e-9


def planck_bands(T):  # photosite's blackbody_rgb: the 0.5-nm midpoint rule over each box
    return [midpoint(lambda l: planck(l, T), *BANDS[k]) for k in "RGB"]


def main():
    print("photosite band efficacies K (lm/W), R G B: %.6f %.6f %.6f" % tuple(K_BAND))
    rgb = bands(HP1)
    print("\nCIE HP1 (high-pressure sodium), band integrals (table units x nm), R G B:")
    print("  %.17g, %.17g, %.17g" % tuple(rgb))
    print("  B/R = %.6f   G/R = %.6f" % (rgb[2] / rgb[0], rgb[1] / rgb[0]))
    alt = [rgb[0], rgb[1] - 2.5 * HP1[WL.index(500)], rgb[2] + 2.5 * HP1[WL.index(500)]]
    print("  with the 500-nm sample (Na 498 nm lines) wholly in B: B/R = %.6f   G/R = %.6f"
          % (alt[2] / alt[0], alt[1] / alt[0]))
    ler = photopic(HP1) / band_integral(HP1, 380, 780)
    print("  luminous efficacy of radiation, 380-780 nm, CIE 1931 V: %.1f lm/W (night-photometry.md §0: 395)" % ler)
    print("  share of its 380-780 nm power inside the boxes 400-700 nm: %.4f"
          % (band_integral(HP1, 400, 700) / band_integral(HP1, 380, 780)))
    ratio_hp1 = photopic(HP1, 400, 700) / box_luminance(rgb)
    print("  photopic luminance (V on the SPD, 400-700 nm) / photosite's box luminance: %.4f" % ratio_hp1)
    print("  per cd/m2 of box luminance, R G B (W sr-1 m-2): %.6e %.6e %.6e"
          % tuple(c / box_luminance(rgb) for c in rgb))

    p4 = planck_bands(4000.0)
    print("\nPlanck 4000 K (photosite's LED proxy): B/R = %.6f   G/R = %.6f" % (p4[2] / p4[0], p4[1] / p4[0]))
    planck_spd = [planck(l, 4000.0) for l in WL]
    print("  photopic luminance (V on the SPD, 400-700 nm) / box luminance: %.4f"
          % (photopic(planck_spd, 400, 700) / box_luminance(bands(planck_spd))))
    led = bands(LED_B3)
    print("CIE LED-B3 (phosphor white LED, ~4000 K): B/R = %.6f   G/R = %.6f" % (led[2] / led[0], led[1] / led[0]))
    print("  photopic luminance (V on the SPD, 400-700 nm) / box luminance: %.4f"
          % (photopic(LED_B3, 400, 700) / box_luminance(led)))
    print("  luminous efficacy of radiation, 380-780 nm: %.1f lm/W (night-photometry.md §0: 317)"
          % (photopic(LED_B3) / band_integral(LED_B3, 380, 780)))
    report_chromaticities()
    report_cameras()
    report_led_b_cameras()


def x_bar_fit(l):  # photosite's CIE 1931 fits (Wyman, Sloan & Shirley 2013), as sensor/spectrum.cpp
    return 1.056 * _g(l, 599.8, 37.9, 31.0) + 0.362 * _g(l, 442.0, 16.0, 26.7) - 0.065 * _g(l, 501.1, 20.4, 26.2)


def z_bar_fit(l):
    return 1.217 * _g(l, 437.0, 11.8, 36.0) + 0.681 * _g(l, 459.0, 26.0, 13.8)


CMF = (x_bar_fit, y_bar_fit, z_bar_fit)


def xyz(spd):
    return [band_integral([s * f(l) for s, l in zip(spd, WL)], 380, 780) for f in CMF]


def xyz_metamer(spd):
    """The box radiances whose CIE 1931 XYZ (photosite's fits) equal the SPD's: the colorimetric
    alternative to the band integrals (Cramer's rule on the boxes' XYZ matrix)."""
    m = [[midpoint(f, *BANDS[k]) / 100.0 for k in "RGB"] for f in CMF]
    t = xyz(spd)

    def det(a):
        return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    d = det(m)
    return [det([[t[r] if c == k else m[r][c] for c in range(3)] for r in range(3)]) / d for k in range(3)]


def camera_signals(name, spd, box_rgb=None):
    """A camera preset's raw signal per filter colour for an SPD on the 5-nm grid, two ways: with
    the SPD itself, sum over 400-700 nm of S * QE_c * lambda (trapezoid, QE linear between the
    preset's table points), and through photosite's box basis, sum_k B_k * mean over box k of
    QE_c * lambda (0.5-nm midpoint rule, as the band integrals of the sensor model). Relative units."""
    import pathlib
    import tomllib
    root = pathlib.Path(__file__).resolve().parent.parent
    q = tomllib.loads((root / "presets" / "cameras" / (name + ".toml")).read_text())["qe"]
    wl = q["wavelength_nm"]

    def qe(c, l):
        t = q[c]
        if l <= wl[0]:
            return t[0]
        if l >= wl[-1]:
            return t[-1]
        i = max(j for j in range(len(wl) - 1) if wl[j] <= l)
        f = (l - wl[i]) / (wl[i + 1] - wl[i])
        return t[i] * (1 - f) + t[i + 1] * f

    exact = {c: band_integral([s * qe(c, l) * l for s, l in zip(spd, WL)], 400, 700) for c in "rgb"}
    b = box_rgb if box_rgb is not None else bands(spd)
    box = {c: sum(b[i] * midpoint(lambda l: qe(c, l) * l, *BANDS[k]) / 100.0 for i, k in enumerate("RGB"))
           for c in "rgb"}
    return exact, box


def report_cameras():
    print("\nRaw camera signals (G/R, B/R of the filter colours), the SPD itself against the box basis:")
    planck_spd = [planck(l, 4000.0) for l in WL]
    for cam in ("onsemi-ar0331", "sony-icx267-flea2"):
        for label, spd in (("HP1", HP1), ("Planck 4000 K", planck_spd), ("LED-B3", LED_B3)):
            e, b = camera_signals(cam, spd)
            print("  %-18s %-14s SPD: G/R %.3f B/R %.3f   box: G/R %.3f B/R %.3f   box/SPD: G/R x%.3f B/R x%.3f"
                  % (cam, label, e["g"] / e["r"], e["b"] / e["r"], b["g"] / b["r"], b["b"] / b["r"],
                     (b["g"] / b["r"]) / (e["g"] / e["r"]), (b["b"] / b["r"]) / (e["b"] / e["r"])))
            _, m = camera_signals(cam, spd, xyz_metamer(spd))
            print("  %-18s %-14s XYZ metamer instead of the band integrals:   box/SPD: G/R x%.3f B/R x%.3f"
                  % ("", "", (m["g"] / m["r"]) / (e["g"] / e["r"]), (m["b"] / m["r"]) / (e["b"] / e["r"])))


def report_led_b_cameras():
    print("\nLED street lamps on a grey road, raw G/R and B/R: the night chain's metamer of LED-B (= the SPD's)")
    print("against the Planck proxy at the same CCT (photosite's blackbody_rgb through the box-averaged QE):")
    for cam in ("onsemi-ar0331", "sony-icx267-flea2"):
        for i in range(5):
            e, _ = camera_signals(cam, LED_B[i])
            _, p = camera_signals(cam, [planck(l, LED_B_CCT[i]) for l in WL], planck_bands(LED_B_CCT[i]))
            gr, br, pgr, pbr = e["g"] / e["r"], e["b"] / e["r"], p["g"] / p["r"], p["b"] / p["r"]
            print("  %-18s LED-B%d %d K: G/R %.3f B/R %.3f   Planck: G/R %.3f (%+.1f %%) B/R %.3f (%+.1f %%)"
                  % (cam, i + 1, LED_B_CCT[i], gr, br, pgr, 100 * (pgr / gr - 1), pbr, 100 * (pbr / br - 1)))


def report_chromaticities():
    print("\nChromaticity (photosite's CIE 1931 fits over 380-780 nm) against CIE 015:2018's table:")
    rows = [("HP1", HP1, (0.5330, 0.4150))] + [("LED-B%d" % (i + 1), LED_B[i], LED_B_XY[i]) for i in range(5)]
    for label, spd, pub in rows:
        t = xyz(spd)
        print("  %-7s x %.4f y %.4f (CIE: %.4f, %.4f)" % (label, t[0] / sum(t), t[1] / sum(t), *pub))
    print("Luminous efficacy of radiation, 380-780 nm, CIE 1931 V, against night-photometry.md §0:")
    for i in range(5):
        ler = photopic(LED_B[i]) / band_integral(LED_B[i], 380, 780)
        print("  LED-B%d (%d K): %.1f lm/W (§0: %d)" % (i + 1, LED_B_CCT[i], ler, LED_B_LER[i]))
        # The data read must be CIE's: its efficacy to §0's rounding (0.5 lm/W), its chromaticity to
        # 0.001 (CIE's 4 decimals plus the Wyman fits' error, 0.0006 at most on these six tables).
        t = xyz(LED_B[i])
        if abs(ler - LED_B_LER[i]) > 0.5 or max(abs(t[0] / sum(t) - LED_B_XY[i][0]),
                                                abs(t[1] / sum(t) - LED_B_XY[i][1])) > 0.001:
            raise SystemExit("LED-B%d does not match CIE 015:2018's published values" % (i + 1))
    m = xyz_metamer(HP1)
    print("  HP1's XYZ metamer in the boxes: B/R %.4f G/R %.4f (band integrals: 0.2234, 1.9454)"
          % (m[2] / m[0], m[1] / m[0]))


if __name__ == "__main__":
    main()
