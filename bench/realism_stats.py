"""Classifier two-sample test for `photosite bench realism` (issue 14 §4).

If rendered night images and real night photos come from the same distribution, no classifier
can tell their patches apart better than chance (Lopez-Paz & Oquab, "Revisiting classifier
two-sample tests", ICLR 2017). We train a random forest on hand-made patch features and report its
cross-validated balanced accuracy: 0.5 means indistinguishable, 1.0 always told apart.

- Every image is first resized (area average) to WORK_WIDTH px wide, so that resolution itself
  (the real photos are 1280-1920 px wide, Cityscapes 2048, KITTI 1242) is not a feature.
- Patches: PATCH x PATCH px on a grid, stride PATCH.
- Features per patch (features()): 16-bin luma histogram, 8-bin histogram of the gradient
  magnitude (log-spaced bins), mean B/R and G/R ratios, saturated-highlight fraction (luma >
  0.98), mean luma, luma standard deviation and local contrast (mean |luma - 5x5 box mean|).
- Cross-validation is grouped by image (GroupKFold): no image has patches on both sides of a
  split, else the forest would recognise the image rather than the domain.
- Balanced accuracy is the mean over the two classes of the per-image fraction of correctly
  classified patches, averaged over the class's images. Its standard error treats the image as
  the unit (patches of one image are correlated): SE = 0.5 * sqrt(s_a^2/n_a + s_b^2/n_b), s the
  standard deviation over images of the per-image fraction correct.
"""
import math

import numpy as np
from PIL import Image

WORK_WIDTH = 1024
PATCH = 128
LUMA_BINS = 16
GRAD_EDGES = np.concatenate([[0.0], np.logspace(-3, 0, 8)[1:], [np.inf]])  # 8 bins
HIGHLIGHT = 0.98
TARGET_BA = 0.55


def load_srgb(path, width=None):
    """An image file as float sRGB in [0, 1], H x W x 3; resized (area/box) to `width` if given."""
    im = Image.open(path).convert("RGB")
    if width is not None and im.width != width:
        h = max(1, round(im.height * width / im.width))
        im = im.resize((width, h), Image.BOX)
    return np.asarray(im, dtype=np.float32) / 255.0


def luma(rgb):
    """Rec. 709 luma of sRGB-encoded values (Y' = 0.2126 R' + 0.7152 G' + 0.0722 B')."""
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


def box_mean(a, k):
    """Mean over a k x k window (edges replicated), via an integral image."""
    p = k // 2
    ap = np.pad(a, p, mode="edge")
    c = np.cumsum(np.cumsum(ap, 0), 1)
    c = np.pad(c, ((1, 0), (1, 0)))
    h, w = a.shape
    s = c[k:k + h, k:k + w] - c[:h, k:k + w] - c[k:k + h, :w] + c[:h, :w]
    return s / (k * k)


FEATURE_NAMES = ([f"luma_hist_{i}" for i in range(LUMA_BINS)] + [f"grad_hist_{i}" for i in range(8)] +
                 ["b_over_r", "g_over_r", "highlight_fraction", "mean_luma", "luma_std", "local_contrast"])


def features(patch):
    """The feature vector of one sRGB patch (h x w x 3 floats in [0, 1]), FEATURE_NAMES order."""
    y = luma(patch)
    lh = np.histogram(y, bins=LUMA_BINS, range=(0.0, 1.0))[0] / y.size
    gy, gx = np.gradient(y)
    g = np.hypot(gx, gy)
    gh = np.histogram(g, bins=GRAD_EDGES)[0] / g.size
    eps = 1e-3  # keeps black patches finite: ratio of means, not mean of ratios
    r, gm, b = (patch[..., k].mean() for k in range(3))
    contrast = np.abs(y - box_mean(y, 5)).mean()
    return np.concatenate([lh, gh, [(b + eps) / (r + eps), (gm + eps) / (r + eps),
                                    (y > HIGHLIGHT).mean(), y.mean(), y.std(), contrast]])


def patch_features(rgb):
    """Feature rows for the PATCH x PATCH grid of an image (the remainder at the edges dropped)."""
    h, w = rgb.shape[:2]
    rows = [features(rgb[y:y + PATCH, x:x + PATCH])
            for y in range(0, h - PATCH + 1, PATCH) for x in range(0, w - PATCH + 1, PATCH)]
    return np.array(rows)


def balanced_accuracy_by_image(correct, labels, groups):
    """(balanced accuracy, SE, per-class image counts) from per-patch correctness, per-patch
    class labels (0/1) and image ids; see the module docstring for the formula."""
    per_class = []
    for c in (0, 1):
        fr = [correct[(groups == g)].mean() for g in np.unique(groups[labels == c])]
        per_class.append(np.array(fr))
    ba = 0.5 * (per_class[0].mean() + per_class[1].mean())
    var = sum(a.var(ddof=1) / len(a) if len(a) > 1 else 0.0 for a in per_class)
    return ba, 0.5 * math.sqrt(var), [len(a) for a in per_class]


def photos_needed(se, n_per_class, margin=TARGET_BA - 0.5, z=1.96):
    """Images per class for a 95 % interval of half-width `margin` (0.05: the room between chance
    and the 0.55 target), if the per-image spread stays what it is now: SE scales as 1/sqrt(n)."""
    if se <= 0:
        return n_per_class
    return int(math.ceil(n_per_class * (z * se / margin) ** 2))


def two_sample_test(feats_a, feats_b, n_splits=None, seed=0, sources_a=None, sources_b=None, importances=True,
                    n_estimators=200):
    """Random forest a-vs-b with GroupKFold by image. feats_*: list of per-image feature arrays.
    With sources_a/sources_b (a source name per image: data set or camera), the folds are
    leave-one-source-out instead: the forest never sees the test image's source, so it cannot
    win by recognising a camera or a data set. Balanced accuracy is still per image.
    Returns dict(balanced_accuracy, se, n_a, n_b, photos_needed_per_class, top_features);
    importances=False skips the forest on all patches that names the top features (top_features
    empty), for the permutation test's many repeats. n_estimators: the forest's trees (200 in the
    bench; fewer only in tests on synthetic sets a handful of trees separate)."""
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.model_selection import GroupKFold, LeaveOneGroupOut

    X = np.concatenate(feats_a + feats_b)
    y = np.concatenate([np.zeros(len(f), int) for f in feats_a] + [np.ones(len(f), int) for f in feats_b])
    groups = np.concatenate([np.full(len(f), i) for i, f in enumerate(feats_a + feats_b)])
    pred = np.empty_like(y)
    if sources_a is not None:
        names = list(sources_a) + [f"b:{s}" if s in set(sources_a) else s for s in sources_b]
        split_groups = np.concatenate([np.full(len(f), names[i]) for i, f in enumerate(feats_a + feats_b)])
        splits = LeaveOneGroupOut().split(X, y, split_groups)
    else:
        k = n_splits or min(8, len(feats_a) + len(feats_b))
        splits = GroupKFold(n_splits=k).split(X, y, groups)
    for train, test in splits:
        # class_weight balanced: the two sides have different patch counts.
        rf = RandomForestClassifier(n_estimators=n_estimators, min_samples_leaf=2, class_weight="balanced",
                                    random_state=seed, n_jobs=2)
        rf.fit(X[train], y[train])
        pred[test] = rf.predict(X[test])
    ba, se, (na, nb) = balanced_accuracy_by_image((pred == y).astype(float), y, groups)
    if not importances:
        return {"balanced_accuracy": ba, "se": se, "n_a": na, "n_b": nb,
                "photos_needed_per_class": photos_needed(se, min(na, nb)), "top_features": []}
    # What tells the two apart: impurity importances of a forest fitted on all patches.
    rf = RandomForestClassifier(n_estimators=n_estimators, min_samples_leaf=2, class_weight="balanced",
                                random_state=seed, n_jobs=2).fit(X, y)
    top = [FEATURE_NAMES[i] for i in np.argsort(rf.feature_importances_)[::-1][:4]]
    return {"balanced_accuracy": ba, "se": se, "n_a": na, "n_b": nb,
            "photos_needed_per_class": photos_needed(se, min(na, nb)), "top_features": top}


def permutation_test(feats_a, feats_b, observed_ba, n_permutations, seed=0, n_estimators=200):
    """Monte Carlo permutation test of the classifier two-sample test (Lopez-Paz & Oquab 2017, §3;
    Phipson & Smyth 2010 for the p-value). Under the null hypothesis that the two sets' images are
    exchangeable, the image labels can be shuffled (the side sizes kept) and the same grouped
    cross-validation run again; the balanced accuracies so drawn are the statistic's null
    distribution for these very images, whatever their heterogeneity (camera, city, exposure),
    which the image-level SE above does not capture. p = (1 + #{null >= observed}) / (1 + N):
    the chance of a balanced accuracy at least as high when nothing tells the sets apart.
    The observed accuracy must come from two_sample_test with the same seed and n_estimators.
    Returns dict(p_value, n_permutations, null_median, null_p90, null_p95, null_max)."""
    pool = list(feats_a) + list(feats_b)
    na = len(feats_a)
    rng = np.random.default_rng(seed)
    null = []
    for _ in range(n_permutations):
        order = rng.permutation(len(pool))
        a = [pool[i] for i in order[:na]]
        b = [pool[i] for i in order[na:]]
        null.append(two_sample_test(a, b, seed=seed, importances=False, n_estimators=n_estimators)["balanced_accuracy"])
    null = np.array(null)
    return {"p_value": float((1 + np.sum(null >= observed_ba - 1e-12)) / (1 + len(null))),
            "n_permutations": len(null), "null_median": float(np.median(null)),
            "null_p90": float(np.percentile(null, 90)), "null_p95": float(np.percentile(null, 95)),
            "null_max": float(null.max())}


def real_source_calibration(feats, sources, min_images=2):
    """How well the same test tells one source of real night photos (a data set or a camera) from
    the other real photos: the balanced accuracy a real, coherent source scores against the rest
    of the reference set, beside which a renderer's score reads. Only sources with at least
    min_images images (the grouped folds need one of them in training when another is tested)
    and at least min_images others. Returns a list of dict(source, n_source, n_other,
    balanced_accuracy, se, top_features), sources in sorted order."""
    rows = []
    for s in sorted(set(sources)):
        a = [f for f, q in zip(feats, sources) if q == s]
        b = [f for f, q in zip(feats, sources) if q != s]
        if len(a) < min_images or len(b) < min_images:
            continue
        t = two_sample_test(a, b)
        rows.append({"source": s, "n_source": len(a), "n_other": len(b), "balanced_accuracy": t["balanced_accuracy"],
                     "se": t["se"], "top_features": t["top_features"]})
    return rows
