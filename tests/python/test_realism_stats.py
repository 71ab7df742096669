"""The statistics and features of bench/realism.py and bench/realism_stats.py on synthetic images
whose answers are known in closed form."""
import math
import os
import pathlib
import stat
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "bench"))
import realism  # noqa: E402
import realism_stats as rs  # noqa: E402


def grey(h, w, v):
    return np.full((h, w, 3), v, np.float32)


def test_luma_is_rec709_weights():
    rgb = np.zeros((1, 3, 3), np.float32)
    rgb[0, 0, 0] = rgb[0, 1, 1] = rgb[0, 2, 2] = 1
    # A float32 image times a Python float stays float32: each unit pixel's luma is its weight
    # rounded to float32 (the products by 0 and the sums with 0 are exact), 2^-24 relative at most.
    np.testing.assert_allclose(rs.luma(rgb)[0], [0.2126, 0.7152, 0.0722], rtol=2.0**-24, atol=0)


def test_statistics_of_a_half_dark_half_saturated_image():
    img = grey(100, 200, 0.05)
    img[:, 100:] = 1.0  # right half saturated white: one blob of 100x100 px
    s, h = realism.statistics(img)
    # Exact, as every fraction below (pytest.approx's default rel=1e-6 was no stated bound): a mean
    # of booleans is count/size in float64, here 10000/20000.
    assert s["dark_fraction"] == 0.5
    assert s["highlight_fraction"] == 0.5
    # The even count's middle: the mean of 0.05 and 1, in float32: 0.05 to float32 and its luma's
    # three products and two sums (2^-24 relative each, on 0.05: 1.8e-8, halved in the mean) and the
    # mean's rounding (half an ulp of 0.525, 2^-25 = 3e-8): under 2^-24.
    assert s["median_luma"] == pytest.approx(0.525, abs=2.0**-24)
    # Exact: grey, so the three channels' means are the same sums of the same values; blobs_per_mpx
    # is the same float64 operations as here; the histogram's two bins are 10000/20000 each.
    assert s["b_over_r"] == 1.0 and s["g_over_r"] == 1.0
    assert s["blobs_per_mpx"] == 1 / (100 * 200 / 1e6)
    assert s["blob_median_px"] == 100 * 100
    assert h.sum() == 1.0


def test_blobs_count_8_connected_regions_and_skip_speckle():
    y = np.zeros((50, 50), np.float32)
    y[5:8, 5:8] = 1         # 9 px
    y[8, 8] = 1             # touches the first diagonally: same blob (10 px)
    y[20:22, 30:34] = 0.95  # 8 px, above BLOB_LUMA
    y[40, 40] = 1           # 1 px: speckle, below BLOB_MIN_PX
    y[45:47, 10] = 0.89     # below BLOB_LUMA
    areas = sorted(realism.light_blobs(y))
    assert areas == [8, 10]


def test_colour_ratios_of_a_known_colour():
    s, _ = realism.statistics(grey(10, 10, 0.0) + np.array([0.4, 0.2, 0.1], np.float32))
    # Exact: the three float32 values share their significand (0.4 = 4 * 0.1 and 0.2 = 2 * 0.1,
    # powers of two apart, so also after rounding to float32), and scaling by a power of two
    # commutes with every rounding of the means: the ratios are exactly 1/4 and 1/2.
    assert s["b_over_r"] == 0.25
    assert s["g_over_r"] == 0.5


def test_emd_of_shifted_deltas_is_the_shift():
    a = np.zeros(64)
    b = np.zeros(64)
    a[10] = 1
    b[30] = 1
    # Exact: the cumulative sums are 0s and 1s, 20 of them apart, and /64 is a power of two.
    assert realism.emd(a, b) == 20 / 64
    assert realism.emd(a, a) == 0


def test_features_of_a_flat_patch():
    f = dict(zip(rs.FEATURE_NAMES, rs.features(grey(128, 128, 0.5))))
    assert len(rs.FEATURE_NAMES) == len(rs.features(grey(8, 8, 0.5)))
    assert f["luma_hist_8"] == 1.0  # 0.5 falls in bin 8 of 16 (count/size, exact)
    assert f["grad_hist_0"] == 1.0  # no gradient anywhere
    # Exact: luma is 0.5 * ((w0 + w1) + w2) with the weights in float32 (halving commutes with
    # rounding), and that sum rounds to exactly 1 (checked here), so every luma is 0.5; float32 sums
    # of up to 132^2 halves (the mean, the box filter's integral image) are exact, so the mean is 0.5
    # and the deviations, the standard deviation and the local contrast are 0.
    assert (np.float32(0.2126) + np.float32(0.7152)) + np.float32(0.0722) == 1
    assert f["luma_std"] == 0 and f["local_contrast"] == 0
    assert f["highlight_fraction"] == 0 and f["mean_luma"] == 0.5


def test_features_of_a_ramp_have_its_gradient():
    x = np.linspace(0, 1, 128, dtype=np.float32)
    img = np.repeat(np.repeat(x[None, :, None], 128, 0), 3, 2)  # luma = x: gradient 1/127 per px
    f = dict(zip(rs.FEATURE_NAMES, rs.features(img)))
    g = 1 / 127
    k = int(np.searchsorted(rs.GRAD_EDGES, g, side="right")) - 1
    assert f[f"grad_hist_{k}"] == 1.0  # every pixel's gradient in one bin: count/size, exact
    # The population standard deviation of n equally spaced values i/(n-1) on [0, 1] is
    # sqrt((n+1) / (12 (n-1))) (0.6 % above the continuous uniform's 1/sqrt(12)). Tolerance: float32
    # rounding: luma's three products and two sums (<= 5 eps per value, eps = 2^-24), numpy's
    # pairwise sums of 2^14 values for the mean and the squares (<= (log2(2^14 / 8) + 8) eps = 19 eps
    # each), so under 60 eps on the variance, 30 on the standard deviation; 100 eps allowed.
    n = x.size
    assert f["luma_std"] == pytest.approx(math.sqrt((n + 1) / (12 * (n - 1))), rel=100 * 2.0**-24)


def test_box_mean_of_a_constant_and_of_an_impulse():
    # Exact: the integral image of 3.0s holds integers (exact in float64), each window sums to 75,
    # and 75/25 = 3.
    assert (rs.box_mean(np.full((9, 9), 3.0), 5) == 3.0).all()
    a = np.zeros((9, 9))
    a[4, 4] = 25
    m = rs.box_mean(a, 5)
    # Exact: the integral image's sums of 0 and 25 are integers, 25/25 = 1.
    assert m[4, 4] == 1.0 and m[2, 2] == 1.0 and m[1, 1] == 0


def test_balanced_accuracy_and_its_image_level_standard_error():
    # class 0: two images, all right and half right; class 1: two images, all right.
    correct = np.array([1, 1, 1, 0, 1, 1, 1, 1], float)
    labels = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    groups = np.array([0, 0, 1, 1, 2, 2, 3, 3])
    ba, se, n = rs.balanced_accuracy_by_image(correct, labels, groups)
    # Exact: means of 1s and 0.5s are dyadic, and the SE is the same float64 operations on the same
    # per-image fractions (class 1's variance is 0).
    assert ba == 0.5 * (0.75 + 1.0)
    assert se == 0.5 * math.sqrt(np.var([1, 0.5], ddof=1) / 2)
    assert n == [2, 2]


def test_photos_needed_scales_with_the_variance():
    # SE 0.051 with 8 per class: a +-0.05 interval needs (1.96*0.051/0.05)^2 = 4.0 times the photos.
    assert rs.photos_needed(0.051, 8) == math.ceil(8 * (1.96 * 0.051 / 0.05) ** 2)


def test_two_sample_test_separates_different_and_not_identical_distributions():
    rng = np.random.default_rng(1)
    dark = [rs.patch_features(np.clip(rng.normal(0.1, 0.02, (256, 256, 3)), 0, 1).astype(np.float32))
            for _ in range(6)]
    bright = [rs.patch_features(np.clip(rng.normal(0.6, 0.02, (256, 256, 3)), 0, 1).astype(np.float32))
              for _ in range(6)]
    same = [rs.patch_features(np.clip(rng.normal(0.1, 0.02, (256, 256, 3)), 0, 1).astype(np.float32))
            for _ in range(6)]
    assert rs.two_sample_test(dark, bright)["balanced_accuracy"] == 1.0
    # Same distribution: chance. 12 images x 4 patches; a per-image SE bound of 5 sigma around 0.5
    # (each image's fraction correct is a mean of 4 Bernoulli(1/2): sd 0.25; SE = 0.5*sqrt(2*0.25^2/6) = 0.072).
    t = rs.two_sample_test(dark, same)
    assert abs(t["balanced_accuracy"] - 0.5) <= 5 * 0.5 * math.sqrt(2 * 0.25 ** 2 / 6)


def test_leave_one_source_out_keeps_a_real_difference_and_holds_out_whole_sources():
    rng = np.random.default_rng(2)
    img = lambda mu: rs.patch_features(np.clip(rng.normal(mu, 0.02, (256, 256, 3)), 0, 1).astype(np.float32))
    dark = [img(0.1) for _ in range(4)]
    bright = [img(0.6) for _ in range(4)]
    t = rs.two_sample_test(dark, bright, sources_a=["x", "x", "y", "y"], sources_b=["u", "u", "v", "v"])
    assert t["balanced_accuracy"] == 1.0
    # A source name shared by both sides is still two groups (one per side): no fold may hold
    # every image of one class out of training.
    t = rs.two_sample_test(dark, bright, sources_a=["x", "x", "y", "y"], sources_b=["x", "x", "y", "y"])
    assert t["balanced_accuracy"] == 1.0


def test_blobs_are_attributed_to_the_class_under_most_of_their_pixels(tmp_path):
    """bench/realism_analyse.py: a blob on building pixels counts as 'building/wall', one mostly on
    a car as 'vehicle'; the painted mask has the group colours there."""
    from PIL import Image
    import realism_analyse as ra
    w, h = realism.BLOB_WIDTH, 64  # already at the blob width: no resize
    img = np.zeros((h, w, 3), np.uint8)
    lab = np.full((h, w), 7, np.uint8)  # road
    img[10:20, 100:110] = 255           # 100 px blob on a building
    lab[5:25, 95:115] = 11
    img[30:40, 300:310] = 255           # 100 px blob, 60 px on a car (26), 40 on road
    lab[30:40, 300:306] = 26
    Image.fromarray(img).save(tmp_path / "p.png")
    Image.fromarray(lab).save(tmp_path / "l.png")
    out = ra.blob_classes(tmp_path / "p.png", tmp_path / "l.png", tmp_path / "m.png")
    assert sorted(out) == sorted([(g, 100) for g in ra.GROUPS if g.startswith(("building", "vehicle"))])
    m = np.asarray(Image.open(tmp_path / "m.png"))
    assert tuple(m[15, 105]) == ra.COLOURS[next(g for g in ra.GROUPS if g.startswith("building"))]


def test_csv_written_with_the_umask_mode_like_the_charts(tmp_path):
    """realism.py's CSVs go through mkstemp (0600); they must end up as a plain open() makes a
    file, 0666 less the umask (0644 under the usual 022), as the charts are."""
    old = os.umask(0o022)
    try:
        p = tmp_path / "realism.csv"
        realism.atomic_write_text(str(p), "a,b\n1,2\n")
        assert p.read_text() == "a,b\n1,2\n"
        assert stat.S_IMODE(p.stat().st_mode) == 0o644
        os.umask(0o027)
        realism.atomic_write_text(str(p), "a\n")
        assert stat.S_IMODE(p.stat().st_mode) == 0o640
    finally:
        os.umask(old)
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".tmp-")]


def _noise_images(rng, mu, n):
    """n images of 256x256 grey noise around mu: 4 patches each."""
    return [rs.patch_features(np.clip(rng.normal(mu, 0.02, (256, 256, 3)), 0, 1).astype(np.float32)) for _ in range(n)]


def test_permutation_test_is_small_only_when_the_sets_differ():
    rng = np.random.default_rng(3)
    dark, bright, same = _noise_images(rng, 0.1, 6), _noise_images(rng, 0.6, 6), _noise_images(rng, 0.1, 6)
    n, trees = 19, 20  # 20 trees: grey levels 0.1 and 0.6 apart are split by any one tree
    t = rs.two_sample_test(dark, bright, n_estimators=trees)
    assert t["balanced_accuracy"] == 1.0
    p = rs.permutation_test(dark, bright, t["balanced_accuracy"], n, n_estimators=trees)
    # Only a shuffle that puts the six dark images on one side (2 of the C(12,6) = 924 splits:
    # the split or its mirror) is told apart perfectly; a side holding an image of the other kind
    # gets that image wrong when it is tested. So at most one of 19 shuffles ties (chance of one
    # 19 * 2/924 = 4 %, of two 0.08 %), and p = (1 + ties)/(1 + n) <= 2/20.
    assert p["n_permutations"] == n
    assert p["p_value"] <= 2 / (n + 1)
    assert p["null_max"] <= 1.0 and p["null_median"] < 1.0
    # Exchangeable sets: the observed accuracy is one more draw of the null, p spread over
    # {1/20, ..., 1}; with this seed it is far from the smallest value.
    t = rs.two_sample_test(dark, same, n_estimators=trees)
    p = rs.permutation_test(dark, same, t["balanced_accuracy"], n, n_estimators=trees)
    assert p["p_value"] > 2 / (n + 1)


def test_real_source_calibration_takes_sources_of_two_or_more_photos():
    rng = np.random.default_rng(4)
    feats = _noise_images(rng, 0.1, 3) + _noise_images(rng, 0.6, 3) + _noise_images(rng, 0.35, 1)
    sources = ["x"] * 3 + ["y"] * 3 + ["z"]
    rows = rs.real_source_calibration(feats, sources)
    # z (one photo) cannot be tested by grouped folds: no row.
    assert [r["source"] for r in rows] == ["x", "y"]
    assert [(r["n_source"], r["n_other"]) for r in rows] == [(3, 4), (3, 4)]
    # x (dark) against y (bright) and z (mid grey): x's and y's images are always placed right; z,
    # between them, may go either way: balanced accuracy >= (1 + 3/4)/2.
    for r in rows:
        assert r["balanced_accuracy"] >= 0.875
