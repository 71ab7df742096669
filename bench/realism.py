#!/usr/bin/python3
"""Statistics of night previews against real night photos (issue 14 §4); called by
`photosite bench realism` with the manifest of previews it wrote.

Per image, on the sRGB-encoded preview (statistics()):
  median_luma        median of Rec. 709 luma Y' (sRGB-encoded values)
  dark_fraction      fraction of pixels with Y' < 0.1
  highlight_fraction fraction with Y' > 0.98 (saturated highlights)
  b_over_r, g_over_r mean(B')/mean(R'), mean(G')/mean(R')
  blobs_per_mpx      light blobs per megapixel: 8-connected regions of Y' >= BLOB_LUMA with at
                     least BLOB_MIN_PX pixels (smaller ones are hot pixels and noise speckle),
                     found on the image resized (area average) to BLOB_WIDTH px wide, so that the
                     sizes compare across resolutions (real photos 1280-1920 px wide, Cityscapes
                     2048, KITTI 1242): a lamp covers 2.6x the pixels at 2048 that it does at 1280
  blob_median_px, blob_p90_px  their area distribution (px at BLOB_WIDTH)
  luma_emd           earth mover's (1-D Wasserstein) distance between the image's luma histogram
                     and the pooled histogram of the real photos (for a real photo: of the others,
                     leave-one-out, so that the real spread is not shrunk by self-comparison)
Then the classifier two-sample test of realism_stats.py for every method against the real photos,
its calibration (each real source of two or more photos against the other real photos: what a real
data set scores) and, with --permutations N, each method's permutation p-value.

Writes <out>/realism.csv (one row per method), realism_per_image.csv, realism_classifier.csv,
realism_calibration.csv (the calibration rows and the permutation tests),
realism.png (each statistic: every method's images against the real photos' range) and
realism_speed.png (median luma EMD against ms per frame).
"""
import argparse
import csv
import os
import pathlib
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import realism_stats as rs  # noqa: E402

HIST_BINS = 64
BLOB_LUMA = 0.9
BLOB_MIN_PX = 4
BLOB_WIDTH = 1280
STATS = ["median_luma", "dark_fraction", "highlight_fraction", "b_over_r", "g_over_r", "blobs_per_mpx",
         "blob_median_px", "blob_p90_px", "luma_emd"]


def luma_histogram(y):
    return np.histogram(y, bins=HIST_BINS, range=(0.0, 1.0))[0].astype(float) / y.size


def emd(h1, h2):
    """1-D earth mover's distance between two normalised histograms on the same [0,1] bins:
    the L1 distance of their cumulative sums times the bin width."""
    return float(np.abs(np.cumsum(h1) - np.cumsum(h2)).sum() / len(h1))


def light_blobs(y):
    """Areas (px) of the 8-connected regions of y >= BLOB_LUMA with at least BLOB_MIN_PX pixels."""
    from scipy import ndimage
    lab, n = ndimage.label(y >= BLOB_LUMA, structure=np.ones((3, 3), int))
    if n == 0:
        return np.zeros(0, int)
    areas = np.bincount(lab.ravel())[1:]
    return areas[areas >= BLOB_MIN_PX]


def statistics(rgb, blob_rgb=None):
    """The per-image statistics (all but luma_emd) of an sRGB image in [0,1] and its luma histogram;
    the blob statistics on `blob_rgb` (the image at BLOB_WIDTH) when given, else on `rgb`."""
    y = rs.luma(rgb)
    yb = y if blob_rgb is None else rs.luma(blob_rgb)
    areas = light_blobs(yb)
    r, g, b = (float(rgb[..., k].mean()) for k in range(3))
    eps = 1e-6
    s = {
        "median_luma": float(np.median(y)),
        "dark_fraction": float((y < 0.1).mean()),
        "highlight_fraction": float((y > rs.HIGHLIGHT).mean()),
        "b_over_r": b / max(r, eps),
        "g_over_r": g / max(r, eps),
        "blobs_per_mpx": len(areas) / (yb.size / 1e6),
        "blob_median_px": float(np.median(areas)) if len(areas) else float("nan"),
        "blob_p90_px": float(np.percentile(areas, 90)) if len(areas) else float("nan"),
    }
    return s, luma_histogram(y)


def atomic_write_text(path, text):
    d = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-", suffix=os.path.basename(path))
    umask = os.umask(0)
    os.umask(umask)
    # mkstemp makes the file 0600; give it the mode a plain open() would (0666 less the umask),
    # as the charts and every other bench file have.
    os.chmod(fd, 0o666 & ~umask)
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    print(path)


def to_csv(rows, keys):
    out = [",".join(keys)]
    for r in rows:
        vals = []
        for k in keys:
            v = r.get(k, "")
            vals.append(f"{v:.6g}" if isinstance(v, float) else (f'"{v}"' if isinstance(v, str) and "," in v else str(v)))
        out.append(",".join(vals))
    return "\n".join(out) + "\n"


def real_photos(folder):
    files = sorted(p for p in pathlib.Path(folder).iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    if not files:
        sys.exit(f"{folder}: --real: no .png/.jpg photos in this folder")
    return files


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--manifest", required=True, help="CSV from `photosite bench realism` (method,dataset,frame,file,ms_per_frame,...)")
    ap.add_argument("--real", required=True, help="folder of real night photos")
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--machine", default="")
    ap.add_argument("--no-classifier", action="store_true")
    ap.add_argument("--permutations", type=int, default=0,
                    help="label shuffles for each method's permutation p-value (0: none; one classifier run each)")
    a = ap.parse_args(argv)
    with open(a.manifest) as f:
        manifest = list(csv.DictReader(f))
    if not manifest:
        sys.exit(f"{a.manifest}: empty manifest")
    methods = list(dict.fromkeys(r["method"] for r in manifest))

    per_image, hists, feats, sources = [], {}, {}, {}
    for p in real_photos(a.real):
        rgb = rs.load_srgb(p)
        s, h = statistics(rgb, rs.load_srgb(p, BLOB_WIDTH))
        per_image.append({"method": "real night", "dataset": "night_real", "frame": p.stem, "ms_per_frame": float("nan"), **s})
        hists.setdefault("real night", []).append(h)
        feats.setdefault("real night", []).append(rs.patch_features(rs.load_srgb(p, rs.WORK_WIDTH)))
        sources.setdefault("real night", []).append(p.stem.split("_")[0])  # bdd100k, robotcar, ...
    real_h = np.array(hists["real night"])
    for i, row in enumerate(per_image):  # leave-one-out pooled real histogram
        others = np.delete(real_h, i, axis=0).mean(0) if len(real_h) > 1 else real_h[i]
        row["luma_emd"] = emd(real_h[i], others)
    pooled = real_h.mean(0)
    for r in manifest:
        rgb = rs.load_srgb(r["file"])
        s, h = statistics(rgb, rs.load_srgb(r["file"], BLOB_WIDTH))
        per_image.append({"method": r["method"], "dataset": r["dataset"], "frame": r["frame"],
                          "ms_per_frame": float(r["ms_per_frame"]), **s, "luma_emd": emd(h, pooled)})
        feats.setdefault(r["method"], []).append(rs.patch_features(rs.load_srgb(r["file"], rs.WORK_WIDTH)))
        sources.setdefault(r["method"], []).append(r["dataset"])

    real_rows = [r for r in per_image if r["method"] == "real night"]
    spread = {k: (np.nanmin([r[k] for r in real_rows]), np.nanmax([r[k] for r in real_rows])) for k in STATS}
    for r in per_image:
        for k in STATS:
            lo, hi = spread[k]
            r[f"{k}_inside"] = int(bool(lo <= r[k] <= hi)) if np.isfinite(r[k]) else 0

    # The test's calibration: each real source with two or more photos against the other real
    # photos (realism_stats.real_source_calibration), the score a real data set gets beside which
    # a method's reads.
    calib_rows = []
    if not a.no_classifier:
        for c in rs.real_source_calibration(feats["real night"], sources["real night"]):
            calib_rows.append({"comparison": f"real {c['source']} vs the other real photos", "n_a": c["n_source"],
                               "n_b": c["n_other"], "balanced_accuracy": c["balanced_accuracy"], "se": c["se"],
                               "top_features": " ".join(c["top_features"])})
            print(f"calibration: real {c['source']} ({c['n_source']}) vs the other real photos ({c['n_other']}): "
                  f"balanced accuracy {c['balanced_accuracy']:.3f} +- {c['se']:.3f}; top features: "
                  f"{' '.join(c['top_features'])}")

    summary, clf_rows = [], []
    for m in ["real night"] + methods:
        rows = [r for r in per_image if r["method"] == m]
        row = {"method": m, "images": len(rows),
               "ms_per_frame": float(np.median([r["ms_per_frame"] for r in rows])) if m != "real night" else float("nan")}
        for k in STATS:
            row[k] = float(np.nanmedian([r[k] for r in rows])) if any(np.isfinite(r[k]) for r in rows) else float("nan")
        for k in STATS:
            row[f"{k}_inside_fraction"] = float(np.mean([r[f"{k}_inside"] for r in rows]))
        row["all_inside_fraction"] = float(np.mean([all(r[f"{k}_inside"] for k in STATS) for r in rows]))
        if m != "real night" and not a.no_classifier:
            t = rs.two_sample_test(feats[m], feats["real night"])
            lo = rs.two_sample_test(feats[m], feats["real night"], sources_a=sources[m],
                                    sources_b=sources["real night"])
            t["balanced_accuracy_loso"], t["se_loso"] = lo["balanced_accuracy"], lo["se"]
            row.update({"balanced_accuracy": t["balanced_accuracy"], "balanced_accuracy_se": t["se"],
                        "balanced_accuracy_loso": lo["balanced_accuracy"], "balanced_accuracy_loso_se": lo["se"],
                        "photos_needed_per_class": t["photos_needed_per_class"]})
            clf_rows.append({"method": m, **{k: v for k, v in t.items() if k != "top_features"},
                             "top_features": " ".join(t["top_features"]), "target": rs.TARGET_BA,
                             "met": int(t["balanced_accuracy"] + 2 * t["se"] <= rs.TARGET_BA)})
            print(f"{m:28s} balanced accuracy {t['balanced_accuracy']:.3f} +- {t['se']:.3f} "
                  f"({t['n_a']} vs {t['n_b']} images; {t['photos_needed_per_class']} per class for a +-0.05 interval); "
                  f"top features: {' '.join(t['top_features'])}; leave-one-source-out "
                  f"{lo['balanced_accuracy']:.3f} +- {lo['se']:.3f}")
            if a.permutations > 0:
                pt = rs.permutation_test(feats[m], feats["real night"], t["balanced_accuracy"], a.permutations)
                row["permutation_p"] = pt["p_value"]
                calib_rows.append({"comparison": f"{m} vs real night, {pt['n_permutations']} label shuffles",
                                   "n_a": t["n_a"], "n_b": t["n_b"], "balanced_accuracy": t["balanced_accuracy"],
                                   "se": t["se"], **pt})
                print(f"{'':28s} permutation test ({pt['n_permutations']} label shuffles): p = {pt['p_value']:.3f}; "
                      f"shuffled balanced accuracy median {pt['null_median']:.3f}, 95th percentile "
                      f"{pt['null_p95']:.3f}, max {pt['null_max']:.3f}")
        summary.append(row)

    os.makedirs(a.out_dir, exist_ok=True)
    keys = ["method", "images", "ms_per_frame"] + STATS + ["balanced_accuracy", "balanced_accuracy_se",
                                                           "balanced_accuracy_loso", "balanced_accuracy_loso_se",
                                                           "photos_needed_per_class", "permutation_p", "all_inside_fraction"] + \
        [f"{k}_inside_fraction" for k in STATS]
    atomic_write_text(os.path.join(a.out_dir, "realism.csv"), to_csv(summary, keys))
    atomic_write_text(os.path.join(a.out_dir, "realism_per_image.csv"),
                      to_csv(per_image, ["method", "dataset", "frame", "ms_per_frame"] + STATS + [f"{k}_inside" for k in STATS]))
    if clf_rows:
        atomic_write_text(os.path.join(a.out_dir, "realism_classifier.csv"),
                          to_csv(clf_rows, ["method", "balanced_accuracy", "se", "n_a", "n_b", "photos_needed_per_class",
                                            "target", "met", "balanced_accuracy_loso", "se_loso", "top_features"]))
    if calib_rows:
        atomic_write_text(os.path.join(a.out_dir, "realism_calibration.csv"),
                          to_csv(calib_rows, ["comparison", "n_a", "n_b", "balanced_accuracy", "se", "top_features",
                                              "n_permutations", "p_value", "null_median", "null_p90", "null_p95",
                                              "null_max"]))
    charts(per_image, summary, spread, methods, a.out_dir, a.machine)
    print()
    print(f"{'method':28s} " + " ".join(f"{k[:12]:>12s}" for k in STATS))
    for r in summary:
        print(f"{r['method']:28s} " + " ".join(f"{r[k]:12.4g}" for k in STATS))
    return 0


def charts(per_image, summary, spread, methods, out_dir, machine):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    allm = ["real night"] + methods
    fig, axes = plt.subplots(3, 3, figsize=(13, 10))
    for ax, k in zip(axes.ravel(), STATS):
        lo, hi = spread[k]
        ax.axvspan(lo, hi, color="0.85", label="real spread")
        for i, m in enumerate(allm):
            v = [r[k] for r in per_image if r["method"] == m and np.isfinite(r[k])]
            ax.plot(v, [i] * len(v), "o", ms=4, alpha=0.7, color="k" if m == "real night" else plt.get_cmap("tab20")(i % 20))
        ax.set_yticks(range(len(allm)))
        ax.set_yticklabels(allm if k in (STATS[0], STATS[3], STATS[6]) else [""] * len(allm), fontsize=7)
        if k in ("blobs_per_mpx", "blob_median_px", "blob_p90_px", "highlight_fraction"):
            ax.set_xscale("symlog", linthresh=1e-4 if k == "highlight_fraction" else 1)
            ax.set_xlim(left=0)  # all non-negative; symlog keeps the zeros on the axis
        ax.set_title(k, fontsize=9)
        ax.invert_yaxis()
    fig.suptitle("photosite bench realism: per-image statistics of the sRGB previews; grey = range of the real night photos",
                 fontsize=10)
    fig.tight_layout()
    p = os.path.join(out_dir, "realism.png")
    fig.savefig(p + ".tmp.png", dpi=90)
    os.replace(p + ".tmp.png", p)
    print(p)
    plt.close(fig)

    # Realism against speed: the luma-histogram EMD and the classifier's balanced accuracy (the
    # test that counts) against ms per frame; one colour and marker per method (tab20, so the
    # 12+ methods stay apart).
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    real = next(r for r in summary if r["method"] == "real night")
    axes[0].axhline(real["luma_emd"], color="0.5", ls="--", label="real photos, leave-one-out median")
    axes[1].axhline(rs.TARGET_BA, color="0.5", ls="--", label=f"target {rs.TARGET_BA}")
    axes[1].axhline(0.5, color="0.8", ls=":", label="chance")
    cmap = plt.get_cmap("tab20")
    for i, r in enumerate(r for r in summary if r["method"] != "real night"):
        ms = max(r["ms_per_frame"], 0.1)  # the day photo: 0 ms, drawn at 0.1
        style = dict(color=cmap(i % 20), marker="osD^v<>"[i % 7], ls="none", label=r["method"])
        axes[0].plot(ms, r["luma_emd"], **style)
        if "balanced_accuracy" in r:
            axes[1].errorbar(ms, r["balanced_accuracy"], yerr=r["balanced_accuracy_se"], capsize=3, **style)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel("ms per frame (median; no file I/O)" + (f"\n{machine}" if machine else ""), fontsize=8)
    axes[0].set_ylabel("luma-histogram EMD to the real photos (median)")
    axes[1].set_ylabel("classifier balanced accuracy ± SE (0.5: indistinguishable)")
    axes[1].legend(fontsize=7, loc="lower left")
    fig.suptitle("realism against speed (photosite bench realism)", fontsize=10)
    fig.tight_layout()
    p = os.path.join(out_dir, "realism_speed.png")
    fig.savefig(p + ".tmp.png", dpi=90)
    os.replace(p + ".tmp.png", p)
    print(p)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
