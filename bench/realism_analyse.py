#!/usr/bin/python3
"""What makes photosite's previews distinguishable from real night photos (issue 14 §4, analysis
for docs/realism.md): run after `photosite bench realism --previews DIR` on that folder.

1. Blobs by class. Every light blob of realism.py (8-connected Y' >= BLOB_LUMA, >= BLOB_MIN_PX px
   at BLOB_WIDTH px wide) is attributed to the semantic class that covers most of its pixels (the
   frame's Cityscapes labelIds, resized nearest to the same width). Printed per method: blob count
   and total blob area per class, the median blob size per class. With --masks OUT, a PNG per
   preview: the preview at BLOB_WIDTH, dimmed, with every blob painted in its class's colour
   (written outside the repository: previews are derived from the data sets' frames).
2. Features. The per-image mean of each of the 30 patch features of realism_stats.py for the real
   photos and for each method, the real photos' range, and the forest's importances (impurity and
   permutation importance on held-out images) for photosite against real.

Usage: /usr/bin/python3 bench/realism_analyse.py --previews DIR [--real DIR] [--shared DIR]
       [--masks OUT] [--methods "photosite,photosite camera ISP"]
"""
import argparse
import csv
import pathlib
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import realism  # noqa: E402
import realism_stats as rs  # noqa: E402

# Cityscapes labelIds (cityscapesScripts labels.py) grouped as the light sources that sit on them.
GROUPS = {
    "building/wall (windows, shop panes, lit walls)": {11, 12, 13, 14, 15, 16},
    "pole/sign/light (lamp heads, signals)": {17, 18, 19, 20},
    "vehicle (vehicle lamps)": {26, 27, 28, 29, 30, 31, 32, 33},
    "sky (lamp heads and glare against the sky)": {23},
    "road/sidewalk/parking (pools, markings)": {6, 7, 8, 9, 10},
    "vegetation/terrain": {21, 22},
    "other": set(),
}
COLOURS = {g: c for g, c in zip(GROUPS, [(255, 140, 0), (0, 200, 255), (255, 0, 0), (180, 0, 255),
                                         (0, 255, 0), (255, 255, 0), (255, 255, 255)])}


def group_of(label):
    for g, ids in GROUPS.items():
        if label in ids:
            return g
    return "other"


def labels_path(shared, dataset, frame):
    d = pathlib.Path(shared) / "data"
    if dataset == "cityscapes":
        return d / "cityscapes" / "gtFine" / f"{frame}_gtFine_labelIds.png"
    return d / "kitti" / "semantic" / (frame.removeprefix("kitti_") + ".png")


def blob_classes(preview, labels_file, masks_out=None):
    """[(group, area)] of the preview's blobs; optionally writes the painted mask PNG."""
    from scipy import ndimage
    rgb = rs.load_srgb(preview, realism.BLOB_WIDTH)
    y = rs.luma(rgb)
    lab_img = Image.open(labels_file)
    lab = np.asarray(lab_img.resize((y.shape[1], y.shape[0]), Image.NEAREST))
    cc, n = ndimage.label(y >= realism.BLOB_LUMA, structure=np.ones((3, 3), int))
    out = []
    paint = (rgb * 0.35 * 255).astype(np.uint8) if masks_out else None
    for i, sl in enumerate(ndimage.find_objects(cc), start=1):
        m = cc[sl] == i
        area = int(m.sum())
        if area < realism.BLOB_MIN_PX:
            continue
        ids, counts = np.unique(lab[sl][m], return_counts=True)
        g = group_of(int(ids[np.argmax(counts)]))
        out.append((g, area))
        if paint is not None:
            paint[sl][m] = COLOURS[g]
    if masks_out:
        Image.fromarray(paint).save(masks_out)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--previews", required=True, help="folder with manifest.csv from `photosite bench realism`")
    ap.add_argument("--real", default=None)
    ap.add_argument("--shared", default=str(pathlib.Path(__file__).resolve().parents[1] / ".." / "shared"))
    ap.add_argument("--masks", default=None, help="folder for the painted blob masks (outside the repository)")
    ap.add_argument("--methods", default="photosite")
    ap.add_argument("--no-features", action="store_true")
    a = ap.parse_args(argv)
    real = a.real or str(pathlib.Path(a.shared) / "data" / "night_real")
    with open(pathlib.Path(a.previews) / "manifest.csv") as f:
        manifest = list(csv.DictReader(f))
    methods = [m.strip() for m in a.methods.split(",")]
    if a.masks:
        pathlib.Path(a.masks).mkdir(parents=True, exist_ok=True)

    print("== blobs by the class under them (per frame: class count/area px, at %d px wide) ==" % realism.BLOB_WIDTH)
    for m in methods:
        rows = [r for r in manifest if r["method"] == m]
        allb = []
        for r in rows:
            mask = (str(pathlib.Path(a.masks) / f"{r['frame']}__{m}__blobs.png") if a.masks else None)
            b = blob_classes(r["file"], labels_path(a.shared, r["dataset"], r["frame"]), mask)
            allb += b
            areas = [x for _, x in b]
            print(f"  {m:24s} {r['frame']:26s} blobs {len(b):4d}  median {np.median(areas) if areas else 0:7.1f}  " +
                  "  ".join(f"{g.split(' ')[0]} {sum(1 for gg, _ in b if gg == g)}/{sum(x for gg, x in b if gg == g)}"
                            for g in GROUPS
                            if any(gg == g for gg, _ in b)))
        total = sum(x for _, x in allb) or 1
        print(f"  {m}: all frames, {len(allb)} blobs, median {np.median([x for _, x in allb]):.1f} px")
        for g in GROUPS:
            xs = [x for gg, x in allb if gg == g]
            if xs:
                print(f"    {g:48s} {len(xs):5d} blobs ({len(xs) / len(allb):5.1%})  area {sum(xs) / total:5.1%}  "
                      f"median {np.median(xs):6.1f} px  p90 {np.percentile(xs, 90):7.1f} px")

    if a.no_features:
        return 0
    print("\n== per-image mean of each patch feature: real range | method values ==")
    reals = sorted(p for p in pathlib.Path(real).iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    fr = [rs.patch_features(rs.load_srgb(p, rs.WORK_WIDTH)) for p in reals]
    fm = {m: [rs.patch_features(rs.load_srgb(r["file"], rs.WORK_WIDTH)) for r in manifest if r["method"] == m]
          for m in methods}
    real_means = np.array([f.mean(0) for f in fr])
    for j, name in enumerate(rs.FEATURE_NAMES):
        line = f"  {name:20s} real {real_means[:, j].min():7.4f}..{real_means[:, j].max():7.4f} (med {np.median(real_means[:, j]):7.4f})"
        for m in methods:
            v = np.array([f.mean(0)[j] for f in fm[m]])
            line += f" | {m[:18]} {v.min():7.4f}..{v.max():7.4f} (med {np.median(v):7.4f})"
        print(line)
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.inspection import permutation_importance
    for m in methods:
        X = np.concatenate(fm[m] + fr)
        y = np.concatenate([np.zeros(len(f), int) for f in fm[m]] + [np.ones(len(f), int) for f in fr])
        g = np.concatenate([np.full(len(f), i) for i, f in enumerate(fm[m] + fr)])
        rf = RandomForestClassifier(n_estimators=200, min_samples_leaf=2, class_weight="balanced", random_state=0,
                                    n_jobs=2).fit(X, y)
        imp = rf.feature_importances_
        # Permutation importance on held-out images: fit without one rendered and one real image
        # at a time is too slow here; one split (even images train, odd test) instead.
        tr = (g % 2) == 0
        rf2 = RandomForestClassifier(n_estimators=200, min_samples_leaf=2, class_weight="balanced", random_state=0,
                                     n_jobs=2).fit(X[tr], y[tr])
        pi = permutation_importance(rf2, X[~tr], y[~tr], scoring="balanced_accuracy", n_repeats=5, random_state=0)
        order = np.argsort(imp)[::-1][:10]
        print(f"\n== {m} vs real: impurity importance (all patches) | permutation importance (train even images, "
              f"test odd; held-out balanced accuracy {rf2.score(X[~tr], y[~tr]):.2f} plain accuracy) ==")
        for i in order:
            print(f"  {rs.FEATURE_NAMES[i]:20s} {imp[i]:.3f} | {pi.importances_mean[i]:+.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
