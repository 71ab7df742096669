"""photosite's Python module against the command line: same numbers, every function."""
import json
import math
import os
import pathlib
import pickle
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import photosite as ps
from conftest import KITTI_IMAGE, KITTI_LABELS, ROOT

KITTI_CAMERA = "sony-icx267-flea2"


@pytest.fixture(scope="module")
def kitti():
    return ps.read_codes(str(KITTI_IMAGE)), ps.read_codes(str(KITTI_LABELS))


def exr_pixels(path):
    channels, attrs, types = ps.read_exr(str(path))
    return channels, attrs, types


def test_imports_without_torch():
    code = "import sys; sys.modules['torch'] = None; import photosite; print(photosite.presets.cameras()[0])"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_presets_match_cli(cli):
    cams = ps.presets.cameras()
    assert "sony-imx174" in cams and "onsemi-ar0331" in cams
    listed = [l.split("\t") for l in cli("presets", "list").stdout.splitlines()]
    assert cams == sorted(n for n, kind, *_ in listed if kind == "camera")
    assert ps.presets.lenses() == sorted(n for n, kind, *_ in listed if kind == "lens")
    assert ps.presets.show("sony-imx174") == json.loads(cli("presets", "show", "sony-imx174", "--json").stdout)
    lens = ps.presets.lenses()[0]
    assert ps.presets.show(lens) == json.loads(cli("presets", "show", lens, "--json").stdout)
    assert "night-urban" in ps.presets.scenes()
    assert ps.presets.scenes() == sorted(n for n, kind, *_ in listed if kind == "scene")
    assert ps.presets.rigs() == sorted(n for n, kind, *_ in listed if kind == "rig") and "kitti" in ps.presets.rigs()
    for name in ("night-urban", "kitti"):  # a scene and a camera rig, as the CLI shows them
        assert ps.presets.show(name) == json.loads(cli("presets", "show", name, "--json").stdout)


def test_preset_names_leave_out_what_is_no_preset_file(tmp_path):
    """A folder named x.toml and a link to nothing in the preset folder are no presets: `presets
    list` names them as such and the errors' "bundled" lists leave them out; the module's name
    lists listed them among the lenses and rigs (thirty-eighth session)."""
    import shutil
    presets = tmp_path / "presets"
    shutil.copytree(ROOT / "presets", presets)
    (presets / "lenses" / "folder.toml").mkdir()
    (presets / "rigs" / "dangling.toml").symlink_to("nowhere.toml")
    code = ("import photosite as ps; print(','.join(ps.presets.lenses())); print(','.join(ps.presets.rigs()))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**os.environ, "PHOTOSITE_PRESET_DIR": str(presets)})
    assert r.returncode == 0, r.stderr
    lenses, rigs = (line.split(",") for line in r.stdout.splitlines())
    assert "folder" not in lenses and "dangling" not in rigs, r.stdout
    assert lenses == ps.presets.lenses() and rigs == ps.presets.rigs()  # the bundled ones, all of them


def test_night_matches_cli_exr_bit_for_bit(kitti, cli, store, tmp_path):
    """Every layer of `photosite night` (frame 1 of 2, seed 5) equals the module's arrays."""
    day, labels = kitti
    out = tmp_path / "night_#.exr"
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 5,
        "--frames", 2, "--exposure-s", 0.03, "--backend", "cpu", "--out", out)
    ch, attrs, types = exr_pixels(tmp_path / "night_1.exr")
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    r = ps.night(day, labels, camera=cam, exposure_s=0.03, seed=5, frame=1, backend="cpu")
    h, w = labels.shape
    assert r.radiance.shape == (h, w, 3) and r.radiance.dtype == np.float32
    assert r.sensor.raw.dtype == np.uint16 and r.sensor.raw.shape == (h, w)
    np.testing.assert_array_equal(ch["raw.Y"], r.sensor.raw.astype(np.float32))
    np.testing.assert_array_equal(ch["electrons.Y"], r.sensor.electrons)
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), r.sensor.rgb)
    np.testing.assert_array_equal(np.stack([ch["night_radiance." + c] for c in "RGB"], -1), r.radiance)
    np.testing.assert_array_equal(np.stack([ch["lights." + c] for c in "RGB"], -1), r.lights)
    np.testing.assert_array_equal(ch["labels.Y"], r.labels.astype(np.float32))
    # depth.Z is stored as half in the EXR (docs/cli.md): equal after the same rounding.
    assert types["depth.Z"] == "half"
    np.testing.assert_array_equal(ch["depth.Z"], r.depth.astype(np.float16).astype(np.float32))
    # the header's sensor attributes are the metadata's; a number attribute reads back as "{:g}"
    # (core/io.cpp), six significant digits: within half a unit of the sixth, 5e-6 relative
    md = r.sensor.metadata
    for key in ("preset", "seed", "frame", "fpn_checksum", "exposure_s"):
        if "photosite/" + key in attrs:
            assert str(md[key]) == attrs["photosite/" + key] or float(md[key]) == pytest.approx(
                float(attrs["photosite/" + key]), rel=0.5e-5)
    assert md["preset"] == KITTI_CAMERA and md["frame"] == 1
    x, y, conf, method = r.vanishing_point
    assert 0 <= x < w and 0 <= y < h and 0 <= conf <= 1 and isinstance(method, str)
    pv = r.preview()
    assert pv.dtype == np.uint8 and pv.shape == (h, w, 3) and pv.flags.owndata is False and pv.base is not None


def test_rig_camera_file_sets_the_metric_scale(kitti, store, tmp_path):
    # Two Cityscapes camera files that differ only in the mounting height, 1.65 m and 3.30 m:
    # flat-ground depth Z = f*h/(y - y_h) doubles, exactly in binary floating point, on the road
    # and sidewalk wherever neither run reaches the preset's 1000 m depth cap (façade planes are
    # fitted with thresholds in metres, so they are not compared). The rig is named in the header.
    day, labels = kitti
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    depth = {}
    for z in (1.65, 3.30):
        f = tmp_path / f"h{z}_camera.json"
        f.write_text(json.dumps({"extrinsic": {"z": z, "pitch": 0.0},
                                 "intrinsic": {"fx": 721.5377, "u0": 1012.5, "v0": 339.5}}))
        r = ps.night(day, labels, camera=cam, backend="cpu", rig=str(f))
        assert r.sensor.metadata["night/camera_rig"] == f.stem and r.sensor.metadata["night/mount_height_m"] == z
        depth[z] = r.depth
        ground = np.isin(r.labels, (7, 8))  # labelIds road, sidewalk
    finite = ground & (depth[1.65] < 500) & (depth[1.65] > 0)
    assert finite.mean() > 0.2  # the road and sidewalks: a quarter of this frame
    np.testing.assert_array_equal(depth[3.30][finite], 2 * depth[1.65][finite])


def test_outputs_own_their_memory(kitti, store):
    day, labels = kitti
    r = ps.night(day, labels, camera=ps.Camera(KITTI_CAMERA, device_store=store), backend="cpu")
    rad = r.radiance
    del r
    assert np.isfinite(rad).all()  # the buffer outlives the result object (capsule-owned)
    assert rad.flags.c_contiguous and not rad.flags.owndata  # no copy: NumPy views the C++ buffer


def test_expose_matches_cli(cli, store, tmp_path):
    rng = np.random.default_rng(1)
    radiance = rng.uniform(0, 0.05, (48, 64, 3)).astype(np.float32)
    ps.write_exr(str(tmp_path / "rad.exr"), {"": radiance})
    cli("expose", "--radiance", tmp_path / "rad.exr", "--preset", "sony-imx174", "--exposure-s", 0.01,
        "--seed", 9, "--backend", "cpu", "--demosaic", "malvar", "--out", tmp_path / "out.exr")
    ch, attrs, _ = exr_pixels(tmp_path / "out.exr")
    cam = ps.Camera("sony-imx174", device_store=store)
    o = cam.expose(radiance, exposure_s=0.01, seed=9, demosaic="malvar", backend="cpu")
    np.testing.assert_array_equal(ch["raw.Y"], o.raw.astype(np.float32))
    np.testing.assert_array_equal(ch["electrons.Y"], o.electrons)
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), o.rgb)
    assert o.metadata["fpn_checksum"] == attrs["photosite/fpn_checksum"]
    # deterministic per (seed, frame), different for another frame
    o2 = cam.expose(radiance, exposure_s=0.01, seed=9, demosaic="malvar", backend="cpu")
    np.testing.assert_array_equal(o.raw, o2.raw)
    o3 = cam.expose(radiance, exposure_s=0.01, seed=9, frame=1, demosaic="malvar", backend="cpu")
    assert (o.raw != o3.raw).any()
    # a grey (H x W) radiance is the same as equal R, G, B
    g = cam.expose(radiance[..., 1].copy(), exposure_s=0.01, seed=9, backend="cpu")
    g3 = cam.expose(np.repeat(radiance[..., 1:2], 3, axis=2), exposure_s=0.01, seed=9, backend="cpu")
    np.testing.assert_array_equal(g.raw, g3.raw)


def test_raw_deeper_than_16_bits_is_uint32_with_the_clis_codes(cli, store, tmp_path):
    # A 20-bit camera (the schema allows up to 24) at K = 100 DN/e-: codes up to 2^20 - 1. .raw was
    # uint16, every code above 65535 wrapped modulo 65536; it must be the CLI's UINT raw.Y exactly.
    import re
    text = (ROOT / "presets/cameras/sony-imx174.toml").read_text()
    text = re.sub(r"(?m)^bit_depth = .*$", "bit_depth = 20", text)
    text = re.sub(r"(?m)^system_gain_dn_per_e = .*$", "system_gain_dn_per_e = 100", text)
    (tmp_path / "bd20.toml").write_text(text)
    radiance = np.random.default_rng(3).uniform(0, 0.05, (48, 64, 3)).astype(np.float32)
    ps.write_exr(str(tmp_path / "rad.exr"), {"": radiance})
    cli("expose", "--radiance", tmp_path / "rad.exr", "--preset", tmp_path / "bd20.toml", "--seed", 4,
        "--backend", "cpu", "--layers", "raw", "--out", tmp_path / "out.exr")
    ch, _, types = exr_pixels(tmp_path / "out.exr")
    o = ps.Camera(str(tmp_path / "bd20.toml"), device_store=store).expose(radiance, seed=4, backend="cpu")
    assert o.raw.dtype == np.uint32
    assert o.raw.max() > 65535  # the case that wrapped
    np.testing.assert_array_equal(o.raw.astype(np.int64), ch["raw.Y"].astype(np.int64))
    # up to 16 bits .raw stays uint16
    assert ps.Camera("sony-imx174", device_store=store).expose(radiance, backend="cpu").raw.dtype == np.uint16


def test_demosaic_matches_cli(cli, tmp_path):
    rng = np.random.default_rng(2)
    mosaic = rng.uniform(0, 1, (32, 40)).astype(np.float32)
    ps.write_exr(str(tmp_path / "m.exr"), {"Y": mosaic})
    cli("demosaic", "--in", tmp_path / "m.exr", "--cfa", "GRBG", "--method", "lmmse", "--backend", "cpu",
        "--out", tmp_path / "rgb.exr")
    ch, _, _ = exr_pixels(tmp_path / "rgb.exr")
    rgb = ps.demosaic(mosaic, cfa="GRBG", method="lmmse", backend="cpu")
    assert rgb.shape == (32, 40, 3) and rgb.dtype == np.float32
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), rgb)
    # uint16 codes are read as code / max code (OpenImageIO's code * (1/65535)): against an exact
    # division each sample differs by at most one float32 rounding (relative 2^-24); bilinear
    # interpolation averages up to 4 such samples, so the result stays within 4 * 2^-24 relative.
    codes = (mosaic * 65535).astype(np.uint16)
    np.testing.assert_allclose(ps.demosaic(codes, backend="cpu"),
                               ps.demosaic((codes.astype(np.float64) / 65535).astype(np.float32), backend="cpu"),
                               rtol=4 * 2.0**-24, atol=0)


def test_demosaic_white_level_matches_cli(cli, tmp_path):
    """RCCB/RCCC clip handling: the same neutral pixels as `photosite demosaic --white-level`."""
    rng = np.random.default_rng(3)
    mosaic = rng.uniform(100, 900, (24, 30)).astype(np.float32)
    mosaic[8:12, 10:15] = 4000.0  # a clipped lamp
    ps.write_exr(str(tmp_path / "m.exr"), {"Y": mosaic})
    for cfa in ("RCCC", "RCCB"):
        out = tmp_path / f"{cfa}.exr"
        cli("demosaic", "--in", tmp_path / "m.exr", "--cfa", cfa, "--method", "malvar", "--backend", "cpu",
            "--white-level", 4000, "--out", out)
        ch, _, _ = exr_pixels(out)
        rgb = ps.demosaic(mosaic, cfa=cfa, method="malvar", backend="cpu", white_level=4000.0)
        np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), rgb)
        # the 3x3 windows of the clipped samples: rows 7..12, columns 9..15, neutral at 4000 / 3
        window = np.zeros(mosaic.shape, bool)
        window[7:13, 9:16] = True
        np.testing.assert_array_equal(rgb[window], np.float32(4000.0 / 3))
        plain = ps.demosaic(mosaic, cfa=cfa, method="malvar", backend="cpu")
        np.testing.assert_array_equal(rgb[~window], plain[~window])
        assert not np.array_equal(rgb[window], plain[window])
    # uint16 codes clip at the code: neutral at a third of code / 65535
    codes = np.full((16, 16), 1000, np.uint16)
    codes[6:9, 6:9] = 65535
    rgb = ps.demosaic(codes, cfa="RCCC", backend="cpu", white_level=65535)
    assert rgb[7, 7, 0] == rgb[7, 7, 1] == rgb[7, 7, 2] == np.float32(1.0 / 3)
    with pytest.raises(ValueError, match="RCCB and RCCC"):
        ps.demosaic(mosaic, cfa="RGGB", white_level=4000.0)
    with pytest.raises(ValueError, match="white_level"):
        ps.demosaic(mosaic, cfa="RCCC", white_level=-1.0)


def test_readers_refuse_a_pipe(tmp_path):
    """A FIFO given to a reader: refused by name (it blocked read_exr, waiting for a writer)."""
    fifo = tmp_path / "pipe.exr"
    os.mkfifo(fifo)

    def unblock():  # should a reader open the FIFO (the old behaviour), feed it junk so the test fails, not hangs
        for _ in range(100):
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)  # succeeds only while a reader has it open
            except OSError:
                time.sleep(0.05)
                continue
            os.write(fd, b"not an image")
            os.close(fd)

    threading.Thread(target=unblock, daemon=True).start()
    for read in (ps.read_exr, ps.read_image):
        with pytest.raises(ValueError, match="not a regular file"):
            read(str(fifo))


def test_characterize_matches_cli(cli, store):
    d = ps.characterize("sony-imx174", roi=32, device_store=store, backend="cpu")
    j = json.loads(cli("characterize", "--preset", "sony-imx174", "--roi", 32, "--json", "--backend", "cpu").stdout)
    assert d == j
    assert len(d["photon_transfer"]) > 5 and d["system_gain_dn_per_e"]["measured"] > 0


def test_chart_matches_cli_bit_for_bit(cli, tmp_path):
    out = tmp_path / "chart.exr"
    cli("chart", "--out", out, "--width", 128, "--height", 96, "--illuminance-lux", 3)
    ch, attrs, _ = ps.read_exr(str(out))
    arr = ps.chart(width=128, height=96, illuminance_lux=3)
    assert arr.shape == (96, 128, 3) and arr.dtype == np.float32
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), arr)
    with pytest.raises(ValueError, match="CCT"):
        ps.chart(cct_k=100)


def test_exr_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    f = rng.normal(size=(5, 7, 3)).astype(np.float32)
    u = rng.integers(0, 60000, (5, 7)).astype(np.uint16)
    p = str(tmp_path / "x.exr")
    ps.write_exr(p, {"a": f, "ids": u}, {"note": "hi", "n": 3, "x": 0.5})
    ch, attrs, types = ps.read_exr(p)
    np.testing.assert_array_equal(np.stack([ch["a." + c] for c in "RGB"], -1), f)
    np.testing.assert_array_equal(ch["ids"], u.astype(np.float32))
    assert types["ids"] == "uint" and types["a.R"] == "float"
    assert attrs["note"] == "hi" and attrs["n"] == "3"
    with pytest.raises(ValueError, match="exists"):
        ps.write_exr(p, {"a": f})  # never overwrite without overwrite=True
    ps.write_exr(p, {"a": f}, overwrite=True)


def test_exr_of_one_row_or_column_round_trips(tmp_path, store):
    """An image of one row or one column is an image (a line profile): written and read back as
    it is; only a sensor frame needs a 2x2 CFA tile."""
    for shape in [(1, 5), (4, 1), (1, 1), (1, 6, 3)]:
        a = np.arange(np.prod(shape), dtype=np.float32).reshape(shape) / 8
        p = str(tmp_path / ("line_%dx%d.exr" % shape[:2]))
        ps.write_exr(p, {"x": a})
        ch, _, _ = ps.read_exr(p)
        got = ch["x"] if a.ndim == 2 else np.stack([ch["x." + c] for c in "RGB"], -1)
        np.testing.assert_array_equal(got, a)
    with pytest.raises(ValueError, match=r"radiance: frame size 5x1 is too small"):
        ps.Camera(KITTI_CAMERA, device_store=store).expose(np.ones((1, 5, 3), np.float32), exposure_s=0.01)


def test_two_threads_run_night_at_once(kitti, store):
    """Both threads' results equal the sequential ones, and the GIL is free during compute: a
    third (main) thread keeps running Python while night works."""
    day, labels = kitti
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    want = [ps.night(day, labels, camera=cam, seed=s, backend="cpu") for s in (1, 2)]
    got = [None, None]

    def work(i):
        got[i] = ps.night(day, labels, camera=cam, seed=i + 1, backend="cpu")

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    stamps = []
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads):
        stamps.append(time.perf_counter())
    total = time.perf_counter() - t0
    for t in threads:
        t.join()
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g.sensor.raw, w.sensor.raw)
        np.testing.assert_array_equal(g.radiance, w.radiance)
    # Had night held the GIL, the main loop would stall for a whole call (>= half of `total`).
    gaps = np.diff(stamps) if len(stamps) > 1 else np.array([total])
    assert gaps.max() < 0.5 * total, (gaps.max(), total)


def test_camera_properties(store):
    cam = ps.Camera("onsemi-ar0331", device_id="cam0", device_store=store)
    assert cam.preset == "onsemi-ar0331" and cam.device_id == "cam0" and cam.device_store == store
    assert cam.lens and cam.width_px > 0 and cam.bit_depth > 0 and cam.cfa
    assert "exposure_s" in ps.night.__doc__ and "W.sr-1.m-2" in ps.night.__doc__


# ---- bad input: ValueError/FileNotFoundError naming the argument, never a crash -----------------
def _day(h=32, w=48, dtype=np.uint8):
    return np.full((h, w, 3), 100, dtype)


def _labels(h=32, w=48, dtype=np.uint8):
    lab = np.full((h, w), 7, dtype)  # road
    lab[: h // 3] = 23  # sky
    return lab


NAN_DAY = _day(dtype=np.float32)
NAN_DAY[3, 4, 1] = np.nan
BAD = [
    ("day float64", lambda: ps.night(_day(dtype=np.float64), _labels()), ValueError, "day_rgb: expected dtype"),
    ("day not contiguous", lambda: ps.night(np.zeros((32, 96, 3), np.uint8)[:, ::2], _labels()), ValueError,
     "C-contiguous"),
    ("day 2 channels", lambda: ps.night(np.zeros((32, 48, 2), np.uint8), _labels()), ValueError,
     "day_rgb: expected 1 or 3 channel(s), got 2"),
    ("day 4 channels", lambda: ps.night(np.zeros((32, 48, 4), np.uint8), _labels()), ValueError, "channel"),
    ("day 4-D", lambda: ps.night(np.zeros((1, 32, 48, 3), np.uint8), _labels()), ValueError, "dimensions"),
    ("day NaN", lambda: ps.night(NAN_DAY, _labels()), ValueError, "not finite"),
    ("day 1x1", lambda: ps.night(np.zeros((1, 1, 3), np.uint8), np.zeros((1, 1), np.uint8)), ValueError,
     "too small"),
    ("labels size", lambda: ps.night(_day(), _labels(16, 48)), ValueError, "labels are 48x16 but the image is 48x32"),
    ("labels float", lambda: ps.night(_day(), _labels().astype(np.float32)), ValueError, "labels: expected dtype"),
    ("labels unknown id", lambda: ps.night(_day(), np.full((32, 48), 200, np.uint8)), ValueError, "labels"),
    ("unknown camera", lambda: ps.Camera("no-such-camera"), ValueError, "no-such-camera"),
    ("unknown scene", lambda: ps.night(_day(), _labels(), scene_preset="no-such-scene"), ValueError,
     "no-such-scene"),
    ("unknown backend", lambda: ps.night(_day(), _labels(), backend="gpu"), ValueError, "unknown backend 'gpu'"),
    ("negative exposure", lambda: ps.night(_day(), _labels(), exposure_s=-1), ValueError, "exposure"),
    ("ambient lux", lambda: ps.night(_day(), _labels(), ambient_lux=50), ValueError, "ambient_lux 50"),
    ("streetlamp type", lambda: ps.night(_day(), _labels(), streetlamp_type="sodium"), ValueError,
     "streetlamp_type 'sodium' is not one of led, hps"),
    ("resize_labels", lambda: ps.night(_day(), _labels(), resize_labels="bicubic"), ValueError, "resize_labels"),
    ("label_format", lambda: ps.night(_day(), _labels(), label_format="png"), ValueError, "png"),
    ("unknown rig", lambda: ps.night(_day(), _labels(), rig="no-such-rig"), ValueError, "no-such-rig"),
    ("demosaic method", lambda: ps.night(_day(), _labels(), demosaic="magic"), ValueError, "magic"),
    ("radiance uint8", lambda: ps.Camera("sony-imx174").expose(np.zeros((8, 8, 3), np.uint8)), ValueError,
     "radiance: expected dtype float32"),
    ("radiance inf", lambda: ps.Camera("sony-imx174").expose(np.full((8, 8, 3), np.inf, np.float32)), ValueError,
     "radiance: sample inf"),
    ("mosaic 3 channels", lambda: ps.demosaic(np.zeros((8, 8, 3), np.float32)), ValueError, "mosaic: expected 1"),
    ("cfa", lambda: ps.demosaic(np.zeros((8, 8), np.float32), cfa="XYZW"), ValueError, "XYZW"),
    ("characterize roi", lambda: ps.characterize("sony-imx174", roi=8), ValueError, "roi 8 must be in [16, 4096]"),
    ("read_exr missing", lambda: ps.read_exr("/nonexistent/x.exr"), FileNotFoundError, "/nonexistent/x.exr"),
    ("read_codes missing", lambda: ps.read_codes("/nonexistent/x.png"), FileNotFoundError, "x.png"),
    ("write_exr bad attribute", lambda: ps.write_exr("/tmp/never.exr", {"a": np.zeros((4, 4), np.float32)},
                                                     {"k": [1]}), ValueError, "attributes['k']"),
    ("write_exr missing folder", lambda: ps.write_exr("/nonexistent/dir/x.exr", {"a": np.zeros((4, 4), np.float32)}),
     ValueError, "/nonexistent/dir"),
    # integer arguments: range-checked at any size, named (not pybind11's signature dump)
    ("seed negative", lambda: ps.night(_day(), _labels(), seed=-1), ValueError,
     "seed -1 must be in [0, 18446744073709551615]"),
    ("seed 2^64", lambda: ps.night(_day(), _labels(), seed=2**64), ValueError, "seed 18446744073709551616 must be in"),
    ("seed float", lambda: ps.night(_day(), _labels(), seed=1.5), TypeError, "seed: expected an int, got float"),
    ("frame 2^32", lambda: ps.night(_day(), _labels(), frame=2**32), ValueError,
     "frame 4294967296 must be in [0, 2147483647]"),
    # the header keeps the frame as a 32-bit int: 2^31 was recorded as -2147483648
    ("frame 2^31", lambda: ps.night(_day(), _labels(), frame=2**31), ValueError,
     "frame 2147483648 must be in [0, 2147483647]"),
    # an empty device_store (an unset variable) was the home store; the CLI refuses --device-store ''
    ("camera device_store empty", lambda: ps.Camera("sony-imx174", device_store=""), ValueError,
     "device_store: an empty folder name is not a device store"),
    ("characterize device_store empty", lambda: ps.characterize("sony-imx174", device_store=""), ValueError,
     "device_store: an empty folder name"),
    ("expose seed negative", lambda: ps.Camera("sony-imx174").expose(np.zeros((8, 8, 3), np.float32), seed=-3),
     ValueError, "seed -3 must be in [0, "),
    ("expose frame negative", lambda: ps.Camera("sony-imx174").expose(np.zeros((8, 8, 3), np.float32), frame=-1),
     ValueError, "frame -1 must be in [0, 2147483647]"),
    ("characterize camera int", lambda: ps.characterize(3), TypeError,
     "camera: expected a Camera or a camera preset name (str), got int"),
    ("characterize roi huge", lambda: ps.characterize("sony-imx174", roi=2**40), ValueError,
     "roi 1099511627776 must be in [16, 4096]"),
    ("characterize seed negative", lambda: ps.characterize("sony-imx174", seed=-1), ValueError, "seed -1 must be in"),
    ("night camera int", lambda: ps.night(_day(), _labels(), camera=3), TypeError,
     "camera: expected a Camera, a camera preset name (str) or None, got int"),
    ("frame_buffer_cache 2^70", lambda: ps.frame_buffer_cache(2**70), ValueError,
     "limit_bytes 1180591620717411303424 must be in [0, 9223372036854775807]"),
    ("chart width 2^40", lambda: ps.chart(width=2**40), ValueError, "width 1099511627776 must be in"),
    ("poisson", lambda: ps.night(_day(), _labels(), poisson="gauss"), ValueError, "unknown Poisson method 'gauss'"),
    ("expose poisson", lambda: ps.Camera("sony-imx174").expose(np.zeros((8, 8, 3), np.float32), poisson="gauss"),
     ValueError, "unknown Poisson method 'gauss'"),
    ("characterize poisson", lambda: ps.characterize("sony-imx174", poisson="gauss"), ValueError,
     "unknown Poisson method 'gauss'"),
]

_Z = np.zeros((4, 4), np.float32)
# write_exr's bad inputs: (id, layers, attributes, message)
BAD_EXR = [
    ("sizes differ", {"a": _Z, "b": np.zeros((5, 4), np.float32)}, {},
     "layers['b']: 4x5 pixels, but layers['a'] is 4x4"),
    ("no layers", {}, {}, "layers: no layers"),
    ("channel twice", {"a": np.zeros((4, 4, 3), np.float32), "a.R": _Z}, {},
     "layers['a.R']: channel 'a.R' is also made by layers['a']"),
    ("empty name 2-D", {"": _Z}, {}, "layers['']: the name \"\" is for an H x W x 3 or 4 layer"),
    ("layer name not str", {1: _Z}, {}, "layers[1]: a layer name must be a str, got int"),
    ("channel name too long", {"c" * 256: _Z}, {}, "channel name of 256 bytes, more than OpenEXR's 255"),
    ("int above int32", {"a": _Z}, {"k": 2**40}, "attributes['k']: 1099511627776 is outside an EXR int attribute's range"),
    ("int below int32", {"a": _Z}, {"k": -2**31 - 1}, "attributes['k']: -2147483649 is outside"),
    ("empty attribute name", {"a": _Z}, {"": 5}, "attributes['']: an attribute name cannot be empty"),
    ("attribute name not str", {"a": _Z}, {(1, 2): 5}, "attributes[(1, 2)]: an attribute name must be a str, got tuple"),
    ("attribute name too long", {"a": _Z}, {"k" * 300: 5}, "a name of 300 bytes, more than OpenEXR's 255"),
    ("text copy taken", {"a": _Z}, {"x": 0.5, "x_text": "y"}, "attributes['x_text']: write_exr writes that name itself"),
    ("unit taken", {"a": _Z}, {"photosite/unit/a": "m"}, "attributes['photosite/unit/a']: reserved"),
] + [(f"reserved {n}", {"a": _Z}, {n: v}, f"attributes['{n}']: reserved")
     for n, v in (("compression", "zip"), ("dataWindow", 1), ("displayWindow", "x"), ("channels", "R"),
                  ("lineOrder", 0), ("pixelAspectRatio", 2.0), ("screenWindowCenter", 0.5), ("capDate", "today"))]


@pytest.mark.parametrize("layers,attributes,match", [b[1:] for b in BAD_EXR], ids=[b[0] for b in BAD_EXR])
def test_write_exr_bad_input(layers, attributes, match, tmp_path):
    """Each bad layer or attribute is a ValueError naming it, raised before any file is made."""
    with pytest.raises(ValueError) as e:
        ps.write_exr(str(tmp_path / "x.exr"), layers, attributes)
    assert match in str(e.value), str(e.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name,call,exc,match", BAD, ids=[b[0] for b in BAD])
def test_bad_input(name, call, exc, match, store):
    with pytest.raises(exc) as e:
        call()
    assert match in str(e.value), str(e.value)


@pytest.mark.parametrize("py_call,cli_args", [
    # `presets show` also lists lenses (508080d); characterize loads a camera as Camera() does
    (lambda: ps.Camera("no-such-camera"), ["characterize", "--preset", "no-such-camera"]),
    (lambda: ps.night(_day(), _labels(), exposure_s=-1, camera=KITTI_CAMERA),
     ["night", "--preset", KITTI_CAMERA, "--exposure-s", "-1", "--out", "/tmp/never.exr"]),
])
def test_bad_input_message_is_the_clis(py_call, cli_args, cli):
    with pytest.raises(ValueError) as e:
        py_call()
    r = cli(*cli_args, check=False)
    assert r.returncode == 2
    # The same library message; a named parameter is spelled as each face spells it (keyword, flag).
    msg = str(e.value)
    for keyword in ("exposure_s",):
        if msg.startswith(keyword):
            msg = "--" + keyword.replace("_", "-") + msg[len(keyword):]
    assert msg in r.stderr, (msg, r.stderr)


def test_camera_preview_matches_cli(kitti, cli, store, tmp_path):
    """preview(isp="camera") is `night --preview-isp camera`'s PNG, byte for byte; it differs from
    the simple preview, and bad values raise ValueError naming the keyword."""
    from PIL import Image
    day, labels = kitti
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 5,
        "--exposure-s", 0.03, "--backend", "cpu", "--out", tmp_path / "n.exr", "--preview", tmp_path / "n.png",
        "--preview-isp", "camera", "--preview-denoise", 2, "--preview-jpeg-quality", 80)
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    r = ps.night(day, labels, camera=cam, exposure_s=0.03, seed=5, backend="cpu")
    pv = r.preview(isp="camera", denoise=2, jpeg_quality=80)
    np.testing.assert_array_equal(pv, np.asarray(Image.open(tmp_path / "n.png").convert("RGB")))
    assert not np.array_equal(pv, r.preview())
    with pytest.raises(ValueError, match="denoise"):
        r.preview(isp="camera", denoise=-1)
    with pytest.raises(ValueError, match="jpeg_quality"):
        r.sensor.preview(isp="camera", jpeg_quality=101)
    # Any Python int is range-checked (pybind11's int caster answered 2**40 with the signature).
    with pytest.raises(ValueError, match=r"jpeg_quality 1099511627776 must be in \[0, 100\]"):
        r.preview(isp="camera", jpeg_quality=2**40)
    with pytest.raises(TypeError, match="jpeg_quality: expected an int"):
        r.sensor.preview(jpeg_quality=1.5)
    with pytest.raises(ValueError, match="isp"):
        r.preview(isp="jpeg")


def _import_limit():  # 1 GiB, or a quarter of the machine's memory if less
    return min(1 << 30, os.sysconf("SC_PHYS_PAGES") // 4 * os.sysconf("SC_PAGE_SIZE"))


def test_frame_buffer_cache_is_on_after_import_and_reuses_every_large_buffer(kitti, store):
    # The module turns the library's frame-buffer cache on (the stale rule, 1 GiB); a call
    # repeating the last one then takes every buffer of 1 MiB and more from it: none goes to the
    # allocator.
    assert ps.frame_buffer_cache()["limit_bytes"] == _import_limit()
    assert ps.frame_buffer_cache()["free_stale"] is True
    day, labels = kitti
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    for _ in range(2):  # the first call also makes the device's maps, the second reads them back
        r = ps.night(day, labels, camera=cam, backend="cpu")
        del r  # its arrays' buffers go back to the cache
    before = ps.frame_buffer_cache()
    r = ps.night(day, labels, camera=cam, backend="cpu")
    after = ps.frame_buffer_cache()
    assert after["reused"] > before["reused"]
    assert after["allocated"] == before["allocated"], (before, after)
    assert after["held_bytes"] <= after["limit_bytes"]
    assert after["in_use_bytes"] <= after["peak_bytes"]


def test_frame_buffer_cache_stale_rule_frees_a_size_no_longer_asked_for(kitti, store):
    # Frames of one size, then frames of another (KITTI's differ by a few pixels): under the stale
    # rule the first size's buffers are freed once they have waited past the horizon, with the limit
    # alone they stay beside the second's. Failed before the rule existed.
    day, labels = kitti
    crop = (np.ascontiguousarray(day[:, 8:]), np.ascontiguousarray(labels[:, 8:]))
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    limit = ps.frame_buffer_cache()["limit_bytes"]

    def held_after(free_stale):
        ps.frame_buffer_cache(0)
        ps.frame_buffer_cache(limit, free_stale=free_stale)
        r = ps.night(day, labels, camera=cam, backend="cpu")
        del r
        one_size = ps.frame_buffer_cache()["held_bytes"]
        start = ps.frame_buffer_cache()["allocated"] + ps.frame_buffer_cache()["reused"]
        horizon = ps.frame_buffer_cache()["stale_after_requests"] or 512
        while ps.frame_buffer_cache()["allocated"] + ps.frame_buffer_cache()["reused"] - start <= horizon + 64:
            r = ps.night(*crop, camera=cam, backend="cpu")
            del r
        return one_size, ps.frame_buffer_cache()["held_bytes"]

    try:
        one, with_rule = held_after(True)
        _, without = held_after(False)
        # The crop's buffers alone (a little smaller than the first size's) against both sizes'.
        assert with_rule <= one, (one, with_rule, without)
        assert without > 1.5 * one, (one, with_rule, without)
        with pytest.raises(TypeError, match="free_stale: expected a bool or None, got str"):
            ps.frame_buffer_cache(free_stale="yes")
    finally:
        ps.frame_buffer_cache(0)
        ps.frame_buffer_cache(limit, free_stale=True)


def test_frame_buffer_cache_does_not_change_results(kitti, store):
    # A reused buffer holds another frame's samples where fresh memory holds zeros: frame A alone
    # with the cache off, then frame B and A again with it on, give A's arrays to the bit.
    day, labels = kitti
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    outputs = lambda r: [r.radiance, r.lights, r.depth, r.sensor.raw, r.sensor.rgb, r.sensor.electrons]
    limit = ps.frame_buffer_cache()["limit_bytes"]
    try:
        ps.frame_buffer_cache(0)
        ref = outputs(ps.night(day, labels, camera=cam, backend="cpu", seed=3))
        ps.frame_buffer_cache(limit)
        flipped = ps.night(np.ascontiguousarray(day[:, ::-1]), np.ascontiguousarray(labels[:, ::-1]), camera=cam,
                           backend="cpu", seed=4)
        del flipped
        reused = ps.frame_buffer_cache()["reused"]
        again = outputs(ps.night(day, labels, camera=cam, backend="cpu", seed=3))
        assert ps.frame_buffer_cache()["reused"] > reused
        for a, b in zip(ref, again):
            np.testing.assert_array_equal(a, b)
    finally:
        ps.frame_buffer_cache(limit)


def test_frame_buffer_cache_limit(store):
    limit = ps.frame_buffer_cache()["limit_bytes"]
    try:
        assert ps.frame_buffer_cache(0) == {**ps.frame_buffer_cache(), "limit_bytes": 0, "held_bytes": 0,
                                            "held_buffers": 0}
        with pytest.raises(ValueError, match="limit_bytes is -1: must be 0 or more"):
            ps.frame_buffer_cache(-1)
    finally:
        ps.frame_buffer_cache(limit)


def test_array_sides_of_2_31_or_more_are_refused(tmp_path):
    # A sparse 2 x (2^32 + 4) file: its width cast to int would read as 4.
    m = np.memmap(tmp_path / "sparse.bin", dtype=np.uint8, mode="w+", shape=(2, 2**32 + 4))
    with pytest.raises(ValueError, match=r"mosaic: frame size too large: 4294967300x2"):
        ps.demosaic(m, backend="cpu")
    with pytest.raises(ValueError, match=r"layers\['a'\]: frame size too large"):
        ps.write_exr(str(tmp_path / "x.exr"), {"a": m})
    assert not (tmp_path / "x.exr").exists()
    del m


def test_night_streetlamp_type_is_the_clis(kitti, cli, store, tmp_path):
    """streetlamp_type= is `night --streetlamp-type`: the same lights bit for bit, and the metadata
    records the type (the preset's "led" without it)."""
    day, labels = kitti
    out = tmp_path / "hps.exr"
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--streetlamp-type",
        "hps", "--layers", "lights", "--backend", "cpu", "--out", out)
    ch, attrs, _ = exr_pixels(out)
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    r = ps.night(day, labels, camera=cam, backend="cpu", streetlamp_type="hps")
    np.testing.assert_array_equal(np.stack([ch["lights." + c] for c in "RGB"], -1), r.lights)
    assert attrs["photosite/scene/lamps.streetlamp_type"] == "hps"
    assert r.sensor.metadata["scene/lamps.streetlamp_type"] == "hps"
    led = ps.night(day, labels, camera=cam, backend="cpu")
    assert led.sensor.metadata["scene/lamps.streetlamp_type"] == "led"
    assert not np.array_equal(led.lights, r.lights)


@pytest.mark.parametrize("bits", [8, 16])
def test_night_grey_day_matches_cli(bits, kitti, cli, store, tmp_path):
    """An H x W day array is `night --image grey.png` (8- or 16-bit): every layer bit for bit."""
    from PIL import Image
    day, labels = kitti
    grey = day.astype(np.uint32).sum(axis=2) // 3
    grey = (grey * 257).astype(np.uint16) if bits == 16 else grey.astype(np.uint8)
    png = tmp_path / "grey.png"
    Image.fromarray(grey).save(png)
    codes = ps.read_codes(str(png))
    assert codes.dtype == grey.dtype and codes.shape == labels.shape
    np.testing.assert_array_equal(codes, grey)
    cli("night", "--image", png, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 3, "--backend", "cpu",
        "--out", tmp_path / "n.exr")
    ch, _, _ = exr_pixels(tmp_path / "n.exr")
    r = ps.night(grey, labels, camera=ps.Camera(KITTI_CAMERA, device_store=store), seed=3, backend="cpu")
    np.testing.assert_array_equal(ch["raw.Y"], r.sensor.raw.astype(np.float32))
    np.testing.assert_array_equal(np.stack([ch["night_radiance." + c] for c in "RGB"], -1), r.radiance)
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], -1), r.sensor.rgb)


def test_poisson_keyword_matches_cli(kitti, cli, store, tmp_path):
    """poisson= is the commands' --poisson: expose and night equal the CLI's EXR for a sampler
    other than the default, and the sampler changes the frame (means of 10 e- and more)."""
    rng = np.random.default_rng(4)
    radiance = rng.uniform(0, 0.5, (48, 64, 3)).astype(np.float32)
    ps.write_exr(str(tmp_path / "rad.exr"), {"": radiance})
    cli("expose", "--radiance", tmp_path / "rad.exr", "--preset", "sony-imx174", "--exposure-s", 0.02, "--seed", 2,
        "--backend", "cpu", "--poisson", "cornish-fisher", "--out", tmp_path / "e.exr")
    ch, _, _ = exr_pixels(tmp_path / "e.exr")
    cam = ps.Camera("sony-imx174", device_store=store)
    o = cam.expose(radiance, seed=2, backend="cpu", poisson="cornish-fisher")
    np.testing.assert_array_equal(ch["raw.Y"], o.raw.astype(np.float32))
    assert o.metadata["poisson"] == "cornish-fisher"
    # a frame whose mean is in the corrected normal's range (kPoissonApproxThreshold = 10 e-;
    # below it the cornish-fisher mode samples by exact inversion too)
    assert o.electrons.mean() > 10
    assert (o.raw != cam.expose(radiance, seed=2, backend="cpu").raw).any()
    day, labels = kitti
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 2,
        "--backend", "cpu", "--poisson", "normal", "--out", tmp_path / "n.exr")
    ch, _, _ = exr_pixels(tmp_path / "n.exr")
    r = ps.night(day, labels, camera=ps.Camera(KITTI_CAMERA, device_store=store), seed=2, backend="cpu",
                 poisson="normal")
    np.testing.assert_array_equal(ch["raw.Y"], r.sensor.raw.astype(np.float32))
    assert r.sensor.metadata["poisson"] == "normal"


def test_characterize_temperature_and_poisson_match_cli(cli, store):
    d = ps.characterize("sony-imx174", roi=32, device_store=store, backend="cpu", temperature_c=80,
                        poisson="normal")
    j = json.loads(cli("characterize", "--preset", "sony-imx174", "--roi", 32, "--json", "--backend", "cpu",
                       "--temperature-c", 80, "--poisson", "normal").stdout)
    assert d == j
    cool = ps.characterize("sony-imx174", roi=32, device_store=store, backend="cpu")
    # The dark current doubles every dark_current_doubling_c: at 80 C it is 2^((80 - T)/d) times
    # the preset temperature T's (the same device's mean dark-rate factor on both). Rounding
    # (u = 2^-53): each side's exponent quotient is off by u of its value (8.5 and 1.5 here), which
    # moves 2^x by ln 2 of that, and each side's exp2 and three products round once each (4u),
    # the ratio once more: (ln 2 * (|x_hot| + |x_cool| + |x|) + 9) u relative.
    pr = ps.presets.show("sony-imx174")
    t_ref, dbl, t_cool = pr["dark_current_reference_c"], pr["dark_current_doubling_c"], pr["temperature_c"]
    x_hot, x_cool = (80 - t_ref) / dbl, (t_cool - t_ref) / dbl
    x = x_hot - x_cool
    rel = (math.log(2) * (abs(x_hot) + abs(x_cool) + abs(x)) + 9) * 2.0**-53
    ratio = d["dark_current_e_per_s"]["preset"] / cool["dark_current_e_per_s"]["preset"]
    assert ratio == pytest.approx(2.0**x, rel=rel, abs=0)


def test_characterize_measures_at_exposure_s_as_the_cli(cli, store):
    """exposure_s was accepted and ignored (the sweep ran at 1 ms whatever was asked); now it is
    the photon-transfer sweep's exposure time, as the command's --exposure-s, and recorded."""
    d = ps.characterize("sony-imx174", roi=16, device_store=store, backend="cpu", temperature_c=80, exposure_s=0.5)
    j = json.loads(cli("characterize", "--preset", "sony-imx174", "--roi", 16, "--json", "--backend", "cpu",
                       "--temperature-c", 80, "--exposure-s", 0.5).stdout)
    assert d == j
    assert d["conditions"]["exposure_s"] == 0.5
    short = ps.characterize("sony-imx174", roi=16, device_store=store, backend="cpu", temperature_c=80)
    assert short["conditions"]["exposure_s"] == 0.001
    assert d["read_noise_e"]["preset"] > short["read_noise_e"]["preset"]  # the dark charge's shot noise
    with pytest.raises(ValueError, match=r"exposure_s -1 s is impossible"):
        ps.characterize("sony-imx174", roi=16, device_store=store, exposure_s=-1)


def test_relative_device_store_is_taken_once(tmp_path):
    """A relative device_store was taken against the working folder at each expose: after an
    os.chdir the device's maps were drawn again in a second store. Now it is made absolute when
    the Camera is made."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    was = os.getcwd()
    try:
        os.chdir(tmp_path / "a")
        cam = ps.Camera("sony-imx174", device_store="maps")
        assert cam.device_store == str((tmp_path / "a" / "maps").resolve())
        os.chdir(tmp_path / "b")
        cam.expose(np.full((16, 32, 3), 1e-3, np.float32), backend="cpu")
    finally:
        os.chdir(was)
    assert (tmp_path / "a" / "maps" / "sony-imx174" / "sony-imx174-0_32x16.exr").exists()
    assert not (tmp_path / "b" / "maps").exists()


def test_metadata_is_the_photosite_header_attributes(cli, store, tmp_path):
    """SensorResult.metadata (docs/python.md): the header's photosite/ attributes without the
    prefix, less the *_text copies, unit/<channel> and radiance_file; floats at full precision
    (the *_text values), seed a str (a 64-bit value)."""
    radiance = np.random.default_rng(5).uniform(0, 0.05, (48, 64, 3)).astype(np.float32)
    ps.write_exr(str(tmp_path / "rad.exr"), {"": radiance})
    cli("expose", "--radiance", tmp_path / "rad.exr", "--preset", "sony-imx174", "--seed", 7, "--backend", "cpu",
        "--out", tmp_path / "e.exr")
    _, attrs, _ = exr_pixels(tmp_path / "e.exr")
    md = ps.Camera("sony-imx174", device_store=store).expose(radiance, seed=7, backend="cpu").metadata
    p = "photosite/"
    want = {k[len(p):] for k in attrs if k.startswith(p) and not k.endswith("_text")
            and not k.startswith(p + "unit/") and k != p + "radiance_file"}
    assert set(md) == want
    assert md["seed"] == "7" and md["frame"] == 0
    for k, v in md.items():
        if isinstance(v, float):
            assert v == float(attrs[p + k + "_text"]), k


def _stub_signatures():
    import ast
    tree = ast.parse((pathlib.Path(ps.__file__).parent / "__init__.pyi").read_text())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out[node.name] = [a.arg for a in node.args.args]
        elif isinstance(node, ast.ClassDef):
            for f in node.body:
                if isinstance(f, ast.FunctionDef):
                    out[f"{node.name}.{f.name}"] = [a.arg for a in f.args.args]
    return out


def test_stubs_name_every_parameter():
    """__init__.pyi's parameters are the functions' own, in order (night's rig= was missing)."""
    import inspect
    import re
    stubs = _stub_signatures()
    for name in ps.__all__:
        f = getattr(ps, name)
        if inspect.isfunction(f):
            assert stubs[name] == list(inspect.signature(f).parameters), name
    # pybind11's methods: the names in their docstring's signature line
    for cls, meth in (("Camera", "expose"), ("SensorResult", "preview"), ("NightResult", "preview")):
        doc = getattr(getattr(ps, cls), meth).__doc__.splitlines()[0]
        assert stubs[f"{cls}.{meth}"] == re.findall(r"(\w+):", doc[doc.index("(") + 1:]), (cls, meth, doc)


def test_camera_doc_names_the_device_store_order():
    doc = " ".join(ps.Camera.__doc__.split())
    assert "$PHOTOSITE_DEVICE_STORE, $XDG_DATA_HOME/photosite/devices, ~/.local/share/photosite/devices" in doc


def _fork_run(work, args, timeout_s=120):
    """work(*args) in a process forked from this one; its result, or the failure it raised."""
    import multiprocessing
    with multiprocessing.get_context("fork").Pool(1) as pool:
        return pool.apply_async(work, args).get(timeout=timeout_s)


def _expose_small(store, backend):
    cam = ps.Camera("sony-imx174", device_id="fork-test", device_store=store)
    rad = np.full((32, 48, 3), 0.01, np.float32)
    return cam.expose(rad, exposure_s=0.02, seed=5, backend=backend).raw


def test_forked_child_runs_after_the_parent_used_openmp(store):
    """GNU OpenMP's thread team does not survive fork(): a child whose parent had run a parallel
    region hung in its first one. The child now runs its regions on one thread: the same bits."""
    parent = _expose_small(store, "cpu")
    child = _fork_run(_expose_small, (store, "cpu"))
    assert np.array_equal(parent, child)


def _vulkan_then(store, backend):
    try:
        return "ok", _expose_small(store, backend)
    except ValueError as e:
        return "error", str(e)


def test_forked_child_refuses_the_parents_vulkan_device(store):
    """A Vulkan device opened before fork() cannot be used in the child (its driver threads are
    gone: the child's first submission waited for ever). Explicit 'vulkan' is refused with the
    reason; 'auto' runs the CPU path, which gives the same bits."""
    try:
        parent = _expose_small(store, "vulkan")
    except ValueError as e:
        pytest.skip(f"*** no Vulkan device here, the fork test needs one: {e} ***")
    kind, what = _fork_run(_vulkan_then, (store, "vulkan"))
    assert kind == "error" and "forked" in what and "spawn" in what, what
    kind, raw = _fork_run(_vulkan_then, (store, "auto"))
    assert kind == "ok" and np.array_equal(raw, parent)


def test_wrong_argument_type_names_the_argument(store):
    """pybind11's TypeError for a wrong argument type listed every signature and the repr of every
    argument (25 KB for a small list), naming none; now it names the argument and both types."""
    cam = ps.Camera("sony-imx174", device_store=store)
    rad = np.zeros((4, 4, 3), np.float32)
    cases = [
        (lambda: cam.expose([[0.0] * 3] * 4), "Camera.expose(): radiance: expected numpy.ndarray, got list"),
        (lambda: cam.expose(rad, exposure_s="0.02"), "Camera.expose(): exposure_s: expected float, got str"),
        (lambda: ps.demosaic([[1, 2], [3, 4]]), "demosaic(): mosaic: expected numpy.ndarray, got list"),
    ]
    for call, message in cases:
        with pytest.raises(TypeError) as e:
            call()
        assert str(e.value) == message
    assert cam.expose(rad).raw.shape == (4, 4)  # the right types still go through


def test_ccm_preview_matches_cli(kitti, cli, store, tmp_path):
    """preview(ccm="camera") is `night --preview-ccm camera`'s PNG, byte for byte (simple ISP); it
    differs from the preview without the matrix, and a bad value raises ValueError naming ccm."""
    from PIL import Image
    day, labels = kitti
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 5,
        "--exposure-s", 0.03, "--backend", "cpu", "--out", tmp_path / "n.exr", "--preview", tmp_path / "n.png",
        "--preview-ccm", "camera")
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    r = ps.night(day, labels, camera=cam, exposure_s=0.03, seed=5, backend="cpu")
    pv = r.preview(ccm="camera")
    np.testing.assert_array_equal(pv, np.asarray(Image.open(tmp_path / "n.png").convert("RGB")))
    assert not np.array_equal(pv, r.preview())
    with pytest.raises(ValueError, match="ccm: 'srgb' is not none or camera"):
        r.sensor.preview(ccm="srgb")


def test_auto_wb_preview_matches_cli(kitti, cli, store, tmp_path):
    """preview(wb="auto") is `night --preview-wb auto`'s PNG, byte for byte (camera ISP, as the test
    above); it differs from the fixed white balance, and a bad value raises ValueError naming wb."""
    from PIL import Image
    day, labels = kitti
    cli("night", "--image", KITTI_IMAGE, "--labels", KITTI_LABELS, "--preset", KITTI_CAMERA, "--seed", 5,
        "--exposure-s", 0.03, "--backend", "cpu", "--out", tmp_path / "n.exr", "--preview", tmp_path / "n.png",
        "--preview-isp", "camera", "--preview-wb", "auto")
    cam = ps.Camera(KITTI_CAMERA, device_store=store)
    r = ps.night(day, labels, camera=cam, exposure_s=0.03, seed=5, backend="cpu")
    pv = r.preview(isp="camera", wb="auto")
    np.testing.assert_array_equal(pv, np.asarray(Image.open(tmp_path / "n.png").convert("RGB")))
    assert not np.array_equal(pv, r.preview(isp="camera"))
    with pytest.raises(ValueError, match="wb: 'grey' is not fixed or auto"):
        r.sensor.preview(wb="grey")


def test_huge_openmp_team_is_an_import_error_not_a_crash():
    """OMP_NUM_THREADS=100000 crashed the interpreter (SIGSEGV in libgomp) at the first parallel
    loop; the module now refuses it when imported, naming the variable (docs/cli.md "Edge cases")."""
    code = "import photosite as ps; ps.chart(64, 48)"
    env = dict(os.environ, OMP_NUM_THREADS="100000")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "ImportError: OMP_NUM_THREADS: 100000 threads is more than photosite runs a parallel region on" in r.stderr


def test_no_street_lamps_says_why_in_the_metadata(store):
    """A frame with no road (all sky) gets no street lamps, and the metadata says why, as the
    command's header does (photosite/night/street_lamp_note)."""
    day = np.full((128, 256, 3), 90, np.uint8)
    r = ps.night(day, np.full((128, 256), 23, np.uint8), camera=ps.Camera("onsemi-ar0331", device_store=store),
                 backend="cpu")
    assert np.isfinite(r.radiance).all()
    assert r.sensor.metadata["night/street_lamp_source"] == "none"
    assert r.sensor.metadata["night/street_lamp_note"] == "no road at the principal column 20-60 m ahead"


# ---- the thirty-fifth session's edge cases (docs/cli.md "Edge cases (thirty-fifth session)") ----

@pytest.mark.parametrize("layer, dtype, half, bad, match", [
    ("rad", np.float32, False, np.nan, r"layers\['rad'\]: channel rad.G is nan at pixel \(2, 1\): NaN and infinity"),
    ("rad", np.float32, False, -np.inf, r"layers\['rad'\]: channel rad.G is -inf at pixel \(2, 1\)"),
    ("rad", np.float16, False, np.inf, r"layers\['rad'\]: channel rad.G is inf at pixel \(2, 1\)"),
    ("rad", np.float32, True, 1e6, r"channel rad.G is 1000000 at pixel \(2, 1\), beyond a half's largest value 65504"),
])
def test_write_exr_refuses_nan_and_inf_naming_the_layer_and_pixel(layer, dtype, half, bad, match, tmp_path):
    """ps.write_exr wrote the NaN or infinity it was given (and a float32 value beyond a half's
    range as infinity with half=True): photosite's layers are physical quantities, so it is a
    ValueError naming the layer, channel and first pixel, and no file is written."""
    a = np.zeros((3, 4, 3), dtype)
    a[1, 2, 1] = bad
    a[2, 3, 0] = bad  # a later one is not named
    p = tmp_path / "x.exr"
    with pytest.raises(ValueError, match=match):
        ps.write_exr(str(p), {layer: a}, half=half)
    assert not p.exists()
    a[1, 2, 1] = a[2, 3, 0] = 65504 if half else 1
    ps.write_exr(str(p), {layer: a}, half=half)  # the largest finite half is written
    assert ps.read_exr(str(p))[0]["rad.G"][1, 2] == a[1, 2, 1]


def test_night_notes_negative_samples_of_a_float_day_image(store):
    """A linear float32 day image's negative samples are clipped to 0 and counted in the metadata
    (night/image_note), as in the command's header; the frame is that of the clipped image."""
    cam = ps.Camera("onsemi-ar0331", device_store=store)
    labels = np.full((64, 128), 23, np.uint8)
    labels[32:] = 7
    day = np.full((64, 128, 3), 0.2, np.float32)
    clipped = day.copy()
    day[3, 5, 1] = -0.25
    day[3, 6, 0] = -0.01
    clipped[3, 5, 1] = clipped[3, 6, 0] = 0
    r = ps.night(day, labels, camera=cam, backend="cpu")
    assert r.sensor.metadata["night/image_note"] == (
        "2 of 8192 pixels have negative values, clipped to 0; the most negative -0.25 (G at pixel (5, 3))")
    z = ps.night(clipped, labels, camera=cam, backend="cpu")
    assert "night/image_note" not in z.sensor.metadata
    assert np.array_equal(r.radiance, z.radiance)


def test_camera_checks_its_device_id_when_made(store):
    """A device id that cannot name a map file was accepted by Camera() and refused at the first
    expose; now at once."""
    for bad, match in [("../x", "may contain only letters"), ("", "device id is empty"),
                       ("x" * 129, "longer than 128"), (".cam", "starts with '.'")]:
        with pytest.raises(ValueError, match=match):
            ps.Camera("onsemi-ar0331", device_id=bad, device_store=store)
