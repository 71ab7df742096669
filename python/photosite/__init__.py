"""photosite: a camera-sensor simulator with a day-to-night front end, from NumPy.

The same C++ library as the ``photosite`` command, in process: arrays in, arrays out, no files in
between. Arrays are C-contiguous NumPy arrays, H x W (one channel) or H x W x C:

- day images (H x W x 3 or H x W grey): uint8 / uint16 sRGB codes (as in a PNG; read as code /
  max code) or float32 linear,
- labels: uint8 / uint16 Cityscapes labelIds or trainIds (H x W) or the colour palette (H x W x 3),
- radiance: float32, W.sr-1.m-2 (band radiance per R, G, B),
- outputs: uint16 raw DN, float32 DN above black, float32 electrons (e-), uint8 sRGB previews.

Bad input raises ValueError (FileNotFoundError for a missing file) with the message the command
line prints. Computation releases the GIL.

    import photosite as ps
    cam = ps.Camera("onsemi-ar0331")
    night = ps.night(day_rgb, labels, camera=cam, exposure_s=0.02, seed=0)
    night.radiance, night.depth, night.sensor.raw, night.preview()
"""
from __future__ import annotations

import functools
import os
import re
from typing import Optional, Union

import numpy as np

from . import _photosite
from ._photosite import Camera, NightResult, SensorResult
from . import presets

# Fork safety (DataLoader workers, multiprocessing): OpenEXR's thread pool is stopped before a
# fork and restarted in the parent, so a forked child reads EXRs without it; the child runs its
# OpenMP regions on one thread (GNU OpenMP's team does not survive a fork), and a Vulkan device
# the parent opened is refused there (_photosite.cpp, gpu/context.cpp).
os.register_at_fork(before=_photosite._before_fork, after_in_parent=_photosite._after_fork_in_parent,
                    after_in_child=_photosite._after_fork_in_child)


# pybind11 answers an argument of the wrong type (a torch tensor or a list for an array, a string
# for a number) with every accepted signature and the full repr of every argument given (25 KB for
# a small list), naming none. The extension's functions and methods are wrapped so that such a
# TypeError names the first argument whose type does not fit, and what it is, instead.
_SIG = re.compile(r"^\s*1\. \((.*)\) -> ", re.M)


def _split_params(text: str) -> list:
    """'a: int = 1, b: Optional[float] = None' -> [('a', 'int'), ('b', 'Optional[float]')]."""
    out, depth, cur = [], 0, ""
    for ch in text + ",":
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        if ch == "," and depth == 0:
            name, _, rest = cur.strip().partition(":")
            out.append((name.strip(), rest.split("=")[0].strip()))
            cur = ""
        else:
            cur += ch
    return out


def _fits(value, expected: str) -> bool:
    if expected.startswith("Optional["):
        return value is None or _fits(value, expected[len("Optional["):-1])
    if expected.startswith("numpy.ndarray"):
        return isinstance(value, np.ndarray)
    if expected == "float":
        return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if expected == "int":
        return isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if expected == "str":
        return isinstance(value, str)
    if expected == "bool":
        return isinstance(value, (bool, np.bool_))
    return True  # other types: pybind11's own check stands


def _argument_error(name: str, message: str, args: tuple, kwargs: dict) -> Optional[str]:
    m = _SIG.search(message)
    if not m:
        return None
    params = _split_params(m.group(1))
    given = list(zip([p for p, _ in params], args)) + list(kwargs.items())
    types = dict(params)
    for pname, value in given:
        expected = types.get(pname)
        if expected is not None and not _fits(value, expected):
            t = type(value)
            got = t.__name__ if t.__module__ == "builtins" else f"{t.__module__}.{t.__name__}"
            return f"{name}(): {pname}: expected {expected}, got {got}"
    return None


def _named_type_errors(fn, name: str):
    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except TypeError as e:
            better = _argument_error(name, str(e), args, kwargs) if "incompatible function arguments" in str(e) else None
            if better is None:
                raise
            raise TypeError(better) from None
    return call


for _n, _f in list(vars(_photosite).items()):
    if not _n.startswith("_") and type(_f).__name__ == "builtin_function_or_method":
        setattr(_photosite, _n, _named_type_errors(_f, _n))
for _cls in (Camera, NightResult, SensorResult):
    for _n, _m in list(vars(_cls).items()):
        if type(_m).__name__ == "instancemethod" and not _n.startswith("_"):
            setattr(_cls, _n, _named_type_errors(_m, f"{_cls.__name__}.{_n}"))

__all__ = ["Camera", "NightResult", "SensorResult", "night", "chart", "demosaic", "characterize", "read_exr",
           "write_exr", "read_image", "read_codes", "frame_buffer_cache", "presets"]

Camera.__doc__ = """Camera(preset, lens=None, device_id=None, device_store=None)

A camera: a camera preset (bundled name such as "onsemi-ar0331" or a .toml path), a lens preset
(default: the camera's default lens) and one device of it. The device's fixed-pattern maps (PRNU,
DSNU, hot pixels) are created once per device_id and frame size and kept in device_store (default,
the first that is set: $PHOTOSITE_DEVICE_STORE, $XDG_DATA_HOME/photosite/devices,
~/.local/share/photosite/devices), exactly as the command line does (docs/sensor.md). A relative
folder is taken against the working folder when the Camera is made, once: Camera.device_store is
that absolute folder, and a later os.chdir does not move it.

Camera.expose(radiance, exposure_s=0.02, f_number=None, gain_db=0, temperature_c=None, seed=0,
              frame=0, demosaic="bilinear", backend="auto", poisson="exact") -> SensorResult
    radiance     float32 H x W x 3 (or H x W, grey), scene radiance in W.sr-1.m-2
    exposure_s   exposure time in seconds
    f_number     f-number N (None: the lens preset's)
    gain_db      analog gain in dB above the base system gain
    temperature_c  die temperature in deg C (None: the preset's)
    seed, frame  the temporal noise key: results are deterministic per (device, seed, frame);
                 ints, seed in [0, 2^64 - 1], frame in [0, 2^31 - 1]
    demosaic     demosaic method for .rgb (bilinear, malvar, hamilton-adams, lmmse, ...)
    backend      "cpu", "vulkan" or "auto" (a real GPU when present, else cpu)
    poisson      shot-noise sampler: "exact", "cornish-fisher" or "normal" (`expose --poisson`)
Returns .raw (DN mosaic: uint16, or uint32 for a camera of more than 16 bits), .rgb (float32 DN above black), .electrons (float32 e-) and
.metadata (dict: the photosite/ header attributes `photosite expose` writes, without the
"photosite/" prefix, the *_text copies, unit/<channel> and radiance_file; docs/python.md).
"""

CameraLike = Union[Camera, str, None]


def _camera(camera: CameraLike, default: str) -> Camera:
    if camera is None:
        return Camera(default)
    if isinstance(camera, str):
        return Camera(camera)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, a camera preset name (str) or None, got {type(camera).__name__}")
    return camera


def night(day_rgb: np.ndarray, labels: np.ndarray, instances: Optional[np.ndarray] = None,
          camera: CameraLike = None, scene_preset: str = "night-urban", exposure_s: float = 0.02,
          f_number: Optional[float] = None, gain_db: float = 0.0, temperature_c: Optional[float] = None,
          seed: int = 0, frame: int = 0, demosaic: str = "bilinear", backend: str = "auto",
          label_format: str = "auto", ambient_lux: Optional[float] = None,
          resize_labels: str = "none", rig: str = "auto", poisson: str = "exact",
          streetlamp_type: Optional[str] = None) -> NightResult:
    """Translate a day photo to night and expose it through a camera (`photosite night`).

    day_rgb       H x W x 3 or H x W (grey, as `night --image grey.png`), uint8/uint16 sRGB codes (as a
                  PNG holds them) or float32 linear sRGB
    labels        H x W uint8/uint16 Cityscapes labelIds or trainIds, or H x W x 3 palette colours
    instances     H x W uint16 Cityscapes instance ids (class*1000+n), for per-vehicle lights; optional
    camera        a Camera, a camera preset name, or None for "onsemi-ar0331" (Cityscapes' camera)
    scene_preset  scene preset name in presets/scenes or a .toml path ("night-urban", ...)
    exposure_s    exposure time in seconds
    f_number      f-number (None: the lens preset's)
    gain_db       analog gain in dB above the base system gain
    temperature_c die temperature in deg C (None: the preset's)
    seed          scene and temporal-noise seed, an int in [0, 2^64 - 1]
    frame         the frame number (noise key), an int in [0, 2^31 - 1] (the header keeps it as a 32-bit int)
    demosaic      demosaic method of sensor.rgb
    backend       "cpu", "vulkan" or "auto"
    label_format  "auto", "labelIds", "trainIds" or "color"
    ambient_lux   night ambient illuminance (moon + sky glow) in lx, [0, 10] (None: the preset's)
    resize_labels "none" or "nearest" (labels of another size than the image)
    rig           camera rig: "auto" (by aspect ratio), a name in presets/rigs, a .toml path or a
                  Cityscapes camera .json (camera/<split>/<city>/<stem>_camera.json)
    poisson       shot-noise sampler: "exact", "cornish-fisher" or "normal" (`night --poisson`)
    streetlamp_type  the street lamps' light source, "led" (phosphor white LED, CIE LED-B) or "hps"
                  (high-pressure sodium, CIE HP1), each as the camera records its spectrum
                  (None: the preset's lamps.streetlamp_type; `night --streetlamp-type`)

    Returns a NightResult: .radiance (float32 H x W x 3, W.sr-1.m-2), .lights (float32 H x W x 3,
    W.sr-1.m-2), .depth (float32 H x W, metres along the optical axis; sky 65504; from the rig),
    .labels (uint16 labelIds), .vanishing_point (x px, y px, confidence 0..1, method), .sensor (a
    SensorResult; its metadata: the photosite/ attributes of the EXR header) and .preview() (uint8
    sRGB). The pixels equal those of the `photosite night` EXR for the same inputs, camera, seed
    and frame.
    """
    return _photosite.night(day_rgb, labels, instances, _camera(camera, "onsemi-ar0331"), scene_preset,
                            exposure_s, f_number, gain_db, temperature_c, seed, frame, demosaic, backend,
                            label_format, ambient_lux, resize_labels, rig, poisson, streetlamp_type)


def demosaic(mosaic: np.ndarray, cfa: str = "RGGB", method: str = "bilinear", backend: str = "auto",
             white_level: Optional[float] = None) -> np.ndarray:
    """Demosaic a CFA mosaic (`photosite demosaic`).

    mosaic   H x W float32 (any unit, kept) or uint8/uint16 codes (read as code / max code)
    cfa      RGGB, BGGR, GRBG, GBRG, RCCB, RCCC or MONO
    method   bilinear, malvar, hamilton-adams, lmmse, ... (`photosite demosaic --list`)
    backend  "cpu", "vulkan" or "auto"
    white_level  RCCB/RCCC only: the level at which the sensor clipped, in the array's values (codes for
                 uint8/uint16; float data clip at it itself): pixels whose 3x3 window holds a clipped
                 sample come out neutral at a third of it, as `photosite demosaic --white-level` and
                 Camera.expose make them (docs/demosaic.md). None (default): no clip handling, since
                 an array does not say where its sensor clipped.
    Returns float32 H x W x 3 in the mosaic's unit.
    """
    return _photosite.demosaic(mosaic, cfa, method, backend, white_level)


def characterize(camera: Union[Camera, str], lens: Optional[str] = None, device_id: Optional[str] = None,
                 device_store: Optional[str] = None, exposure_s: Optional[float] = None, gain_db: float = 0.0,
                 seed: int = 0, roi: int = 256, wavelength_nm: float = 525.0, backend: str = "auto",
                 temperature_c: Optional[float] = None, poisson: str = "exact") -> dict:
    """EMVA 1288 (R4.0) photon-transfer measurement of a simulated camera (`photosite characterize --json`).

    camera        a Camera or a camera preset name (then lens, device_id, device_store apply)
    exposure_s    exposure time in s of the photon-transfer sweep, the dark pair and the DSNU/PRNU
                  frames (the irradiation varies at that one time, and the figures hold for it),
                  [0, 3600]; None: 1 ms (`characterize --exposure-s`, default 0.001). The dark
                  current is fitted over the plan's own exposures. Before 2026-12-02 it was
                  accepted and ignored.
    gain_db       analog gain in dB
    roi           side of the measured region in pixels, [16, 4096]
    wavelength_nm wavelength of the light in nm
    temperature_c die temperature in deg C (None: the preset's); sets the dark current
    poisson       shot-noise sampler: "exact", "cornish-fisher" or "normal" (`characterize --poisson`)
    Returns the same dict as the command's JSON: per quantity (system_gain_dn_per_e, read_noise_e,
    qe_<wavelength>nm (qe_525nm by default), saturation_capacity_e, dark_current_e_per_s, dsnu_e, prnu_percent, snr_max_db,
    dynamic_range_db) its measured value, uncertainty (1 standard error), preset value and z score,
    and "photon_transfer": [[photons, mean DN above dark, temporal variance above dark DN^2], ...]
    (EMVA 1288's mu_y - mu_y.dark and sigma2_y - sigma2_y.dark; no dark point).
    """
    return _photosite.characterize(camera, lens, device_id, device_store, exposure_s, gain_db, seed, roi,
                                   wavelength_nm, backend, temperature_c, poisson)


def read_exr(path: str) -> tuple:
    """Read an OpenEXR file: (channels, attributes, pixel_types).

    channels     dict channel name -> float32 H x W array (UINT channels exact as float32)
    attributes   dict of the header attributes as text, except the layout (channels, dataWindow,
                 displayWindow, lineOrder): ints in decimal, floats to 6 significant digits (the
                 photosite *_text attributes hold them in full), the compression by name, capDate
                 as "DateTime", other types (screenWindowCenter) as their type name ("v2f")
    pixel_types  dict channel name -> "float", "half" or "uint"
    """
    return _photosite.read_exr(path)


def write_exr(path: str, layers: dict, attributes: Optional[dict] = None, half: bool = False,
              overwrite: bool = False) -> None:
    """Write an OpenEXR file atomically (never a half-written file; an existing one only with overwrite).

    layers      dict name -> array. H x W: one channel named `name`; H x W x 3 or 4: channels
                name.R, name.G, name.B (, name.A), or R, G, B (, A) for the name "".
                float32 -> float (half with half=True), float16 -> half, uint8/16/32 -> uint (exact).
    attributes  dict name -> str, int (32-bit) or float header attributes; a float x is also
                written as the 17-digit text x_text. The header's own names (compression,
                dataWindow, channels, capDate, ...) are refused.
    Bad input (layers of different sizes, a channel made twice, an attribute out of range, NaN or
    infinity in a float layer, a float32 value beyond a half's 65504 with half=True...) is a
    ValueError naming the layer or attribute (and the pixel), raised before any file is made.
    """
    _photosite.write_exr(path, layers, attributes or {}, half, overwrite)


def chart(width: int = 640, height: int = 480, illuminance_lux: float = 10.0, cct_k: float = 3000.0,
          lamp_cd_m2: float = 2e4, background_cd_m2: float = 0.005) -> np.ndarray:
    """The night test chart in radiance (float32 H x W x 3, W.sr-1.m-2), as `photosite chart`
    writes it: the 24 ColorChecker patches under `illuminance_lux` of a `cct_k` black body, a
    20-step grey wedge from 1e-3 to 1e2 cd/m2 and two lamp heads (2000 K, 4000 K) of
    `lamp_cd_m2` on a `background_cd_m2` background. Feed it to Camera.expose()."""
    return _photosite.chart(width, height, illuminance_lux, cct_k, lamp_cd_m2, background_cd_m2)


def read_image(path: str) -> np.ndarray:
    """Read an image as float32 (integer files as code / max code), H x W or H x W x C."""
    return _photosite.read_image(path)


def read_codes(path: str) -> np.ndarray:
    """Read an 8/16-bit image's integer codes unscaled: uint8 for 8-bit files, else uint16
    (day PNGs for night(), label and instance PNGs)."""
    return _photosite.read_codes(path)


def frame_buffer_cache(limit_bytes: Optional[int] = None, free_stale: Optional[bool] = None) -> dict:
    """The library's cache of freed frame buffers: read it, or set its limit in bytes and its stale rule.

    A loop of night() or expose() calls frees and allocates the same full-resolution buffers every
    frame (about 100 MB at 2048x1024). glibc hands large freed buffers back to the kernel, so each
    frame would fault its pages in and have them zeroed again; the module does not change the host
    process's malloc settings, so the library keeps buffers of 1 MiB and more, once freed, for
    reuse by an allocation of the same size.

    On import the stale rule is on and the limit is 1 GiB (a quarter of the machine's memory if
    that is less; per process: a data loader's workers each hold their own). The stale
    rule frees a held buffer once it has waited longer than the longest wait of any buffer reused
    so far and a quarter more (waits counted in requests for buffers, at least 16 of them, not in
    seconds): a loop of one frame size keeps every buffer it frees (about 220 MB at 2048x1024, 778 MB at
    4096x2048), and where the sizes change the sizes no longer asked for are freed a few frames
    later; a size that comes back after the rule freed it teaches the rule that wait. The limit
    caps what is held. limit_bytes=0 frees them all and turns the cache off; free_stale=False
    leaves the limit alone to bound it.

    Returns {"limit_bytes", "held_bytes", "held_buffers", "reused", "allocated", "free_stale",
    "stale_after_requests", "in_use_bytes", "peak_bytes"}: the limit, what it holds now, how many
    buffers of 1 MiB or more were taken from it or from the allocator, the rule and its horizon in
    requests (0 when off), and the bytes of such buffers in use now and at most since import.
    """
    return _photosite.frame_buffer_cache(limit_bytes, free_stale)
