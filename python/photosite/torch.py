"""PyTorch glue: photosite's day-to-night translation as a torchvision-style transform.

    from photosite.torch import NightTransform
    t = NightTransform(camera="onsemi-ar0331", seed=7)
    image, target = t((day_uint8_hwc, labels_hw), index=i)   # in a Dataset's __getitem__(i)

torch is optional: importing photosite works without it; this module needs it.
"""
from __future__ import annotations

import hashlib
import os
from typing import Any, Optional, Tuple

import numpy as np
import torch

from . import Camera, night


def _frame_seed(seed: int, index: int) -> int:
    """The (seed, index) key as one 64-bit seed: SHA-256 of both, so neighbouring indices share
    nothing and the result depends on nothing but (seed, index)."""
    h = hashlib.sha256(f"{int(seed)}:{int(index)}".encode()).digest()
    return int.from_bytes(h[:8], "little") >> 1  # < 2^63, a valid uint64 on every side


class NightTransform:
    """Day (image, target) pair -> night (image, target), deterministic per (seed, index).

    camera        camera preset name (str; a name keeps the transform picklable)
    seed          base seed; the sample's seed is derived from (seed, index)
    exposure_s    exposure time in seconds; other keywords go to photosite.night()
    output        "preview" (uint8 sRGB H x W x 3 -> float tensor 3 x H x W in [0, 1]),
                  "rgb" (float32 DN above black, 3 x H x W) or "raw" (uint16/uint32 DN mosaic as
                  int32 1 x H x W)

    image: H x W x 3 uint8/uint16 NumPy array or a 3 x H x W uint8 tensor; target: H x W labelIds
    (NumPy or tensor). Returns (image tensor, target as a long tensor of labelIds).

    Picklable: only the preset name and settings travel to DataLoader workers; each process opens
    its own Camera (and so its own device store handle) on first use.
    """

    def __init__(self, camera: str = "onsemi-ar0331", seed: int = 0, exposure_s: float = 0.02,
                 output: str = "preview", device_store: Optional[str] = None, **night_kwargs: Any):
        if output not in ("preview", "rgb", "raw"):
            raise ValueError(f"output: '{output}' is not preview, rgb or raw")
        # Checked as photosite.night checks its own (a float seed was truncated by int(), a str
        # exposure raised float()'s message, which names no argument).
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise TypeError(f"seed: expected an int, got {type(seed).__name__}")
        if isinstance(exposure_s, bool) or not isinstance(exposure_s, (int, float, np.integer, np.floating)):
            raise TypeError(f"exposure_s: expected a number of seconds, got {type(exposure_s).__name__}")
        self.camera = camera
        self.seed = int(seed)
        self.exposure_s = float(exposure_s)
        self.output = output
        self.device_store = device_store
        self.night_kwargs = dict(night_kwargs)
        self._cam: Optional[Camera] = None
        self._cam_pid = 0

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_cam"] = None  # each process opens its own
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    def _camera(self) -> Camera:
        # One per process: a forked worker (DataLoader's default on Linux) inherits the parent's
        # Camera object, whose Vulkan device, if it opened one, cannot be used after the fork.
        if self._cam is None or self._cam_pid != os.getpid():
            self._cam = Camera(self.camera, device_store=self.device_store)
            self._cam_pid = os.getpid()
        return self._cam

    @staticmethod
    def _numpy(x) -> np.ndarray:
        if isinstance(x, torch.Tensor):
            x = x.detach().cpu()
            if x.ndim == 3 and x.shape[0] in (1, 3) and x.shape[2] not in (1, 3):
                x = x.permute(1, 2, 0)
            x = x.numpy()
        return np.ascontiguousarray(x)

    @staticmethod
    def _uint16_labels(labels: np.ndarray) -> np.ndarray:
        """Label ids of another dtype as uint16, checked first: a value that is not a whole number
        in [0, 65535] would wrap or round in the cast, so it is refused with the value given."""
        if labels.dtype.kind not in "biuf":
            raise ValueError(f"labels: expected integer label ids, got dtype {labels.dtype}")
        bad = ~((labels >= 0) & (labels <= 65535))
        if labels.dtype.kind == "f":
            bad |= ~np.isfinite(labels) | (labels != np.floor(labels))
        if bad.any():
            pos = tuple(int(i) for i in np.argwhere(bad)[0])
            where = f"pixel ({pos[1]}, {pos[0]})" if len(pos) >= 2 else f"index {pos}"
            raise ValueError(f"labels: value {labels[pos]} at {where} is not a label id in 0..65535 "
                             f"(uint16 labelIds, trainIds or palette values)")
        return labels.astype(np.uint16)

    def __call__(self, sample: Tuple[Any, Any], index: Optional[int] = None):
        # The noise is keyed by (seed, index): without the sample's index every sample of one size
        # would get the same noise field (correlation 0.98 between two images' noise).
        if index is None or isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            got = "nothing" if index is None else type(index).__name__
            raise TypeError(f"index: expected the sample's int index, got {got}; call t((image, target), index=i) "
                            "(the noise is keyed by (seed, index))")
        if not isinstance(sample, (tuple, list)) or len(sample) != 2:
            raise TypeError(f"sample: expected an (image, target) pair, got {type(sample).__name__}")
        image, target = sample
        day = self._numpy(image)
        if day.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"image: expected 8- or 16-bit sRGB codes (uint8 or uint16), got {day.dtype}; a float "
                             "image would be read as linear (torchvision's ToTensor output is sRGB in [0, 1]): pass "
                             "the uint8 image, or call photosite.night with a linear float image")
        labels = self._numpy(target)
        if labels.dtype not in (np.uint8, np.uint16):
            labels = self._uint16_labels(labels)
        r = night(day, labels, camera=self._camera(), exposure_s=self.exposure_s,
                  seed=_frame_seed(self.seed, index), frame=0, **self.night_kwargs)
        if self.output == "preview":
            img = torch.from_numpy(r.preview()).permute(2, 0, 1).float().div_(255.0)
        elif self.output == "rgb":
            img = torch.from_numpy(r.sensor.rgb).permute(2, 0, 1)
        else:
            img = torch.from_numpy(r.sensor.raw.astype(np.int32))[None]
        return img, torch.from_numpy(r.labels.astype(np.int64))

    def __repr__(self):
        return (f"NightTransform(camera={self.camera!r}, seed={self.seed}, exposure_s={self.exposure_s}, "
                f"output={self.output!r})")
