# Type stubs for photosite (arrays: C-contiguous NumPy; units in the names and docstrings).
from typing import Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import presets as presets

class SensorResult:
    raw: npt.NDArray[np.uint16]        # H x W raw DN mosaic (with black level)
    rgb: npt.NDArray[np.float32]       # H x W x 3 demosaiced DN above black
    electrons: npt.NDArray[np.float32] # H x W collected e-
    metadata: Dict[str, Union[str, int, float]]  # the photosite/ header attributes, without the prefix (docs/python.md)
    def preview(self, isp: str = "simple", denoise: float = 1.0, jpeg_quality: int = 90, wb: str = "fixed", ccm: str = "none") -> npt.NDArray[np.uint8]: ...  # H x W x 3 sRGB

class NightResult:
    radiance: npt.NDArray[np.float32]  # H x W x 3, W.sr-1.m-2
    lights: npt.NDArray[np.float32]    # H x W x 3, W.sr-1.m-2
    depth: npt.NDArray[np.float32]     # H x W, metres along the optical axis (sky 65504)
    labels: npt.NDArray[np.uint16]     # H x W Cityscapes labelIds
    vanishing_point: Tuple[float, float, float, str]  # x px, y px, confidence 0..1, method
    sensor: SensorResult
    chain_ms: float                    # the library chain's time in ms
    def preview(self, isp: str = "simple", denoise: float = 1.0, jpeg_quality: int = 90, wb: str = "fixed", ccm: str = "none") -> npt.NDArray[np.uint8]: ...

class Camera:
    preset: str
    lens: str
    device_id: str
    device_store: str
    width_px: int
    height_px: int
    bit_depth: int
    cfa: str
    def __init__(self, preset: str, lens: Optional[str] = ..., device_id: Optional[str] = ...,
                 device_store: Optional[str] = ...) -> None: ...
    def expose(self, radiance: npt.NDArray[np.float32], exposure_s: float = ..., f_number: Optional[float] = ...,
               gain_db: float = ..., temperature_c: Optional[float] = ..., seed: int = ..., frame: int = ...,
               demosaic: str = ..., backend: str = ..., poisson: str = ...) -> SensorResult: ...

CameraLike = Union[Camera, str, None]

def night(day_rgb: npt.NDArray[Union[np.uint8, np.uint16, np.float32]],  # H x W x 3 or H x W (grey)
          labels: npt.NDArray[Union[np.uint8, np.uint16]],
          instances: Optional[npt.NDArray[Union[np.uint8, np.uint16]]] = ..., camera: CameraLike = ...,
          scene_preset: str = ..., exposure_s: float = ..., f_number: Optional[float] = ..., gain_db: float = ...,
          temperature_c: Optional[float] = ..., seed: int = ..., frame: int = ..., demosaic: str = ...,
          backend: str = ..., label_format: str = ..., ambient_lux: Optional[float] = ...,
          resize_labels: str = ..., rig: str = ..., poisson: str = ...,
          streetlamp_type: Optional[str] = ...) -> NightResult: ...
def demosaic(mosaic: npt.NDArray[Union[np.float32, np.uint8, np.uint16]], cfa: str = ..., method: str = ...,
             backend: str = ..., white_level: Optional[float] = ...) -> npt.NDArray[np.float32]: ...
def characterize(camera: Union[Camera, str], lens: Optional[str] = ..., device_id: Optional[str] = ...,
                 device_store: Optional[str] = ..., exposure_s: float = ..., gain_db: float = ..., seed: int = ...,
                 roi: int = ..., wavelength_nm: float = ..., backend: str = ..., temperature_c: Optional[float] = ...,
                 poisson: str = ...) -> dict: ...
def read_exr(path: str) -> Tuple[Dict[str, npt.NDArray[np.float32]], Dict[str, str], Dict[str, str]]: ...
def write_exr(path: str, layers: Dict[str, np.ndarray], attributes: Optional[Dict[str, Union[str, int, float]]] = ...,
              half: bool = ..., overwrite: bool = ...) -> None: ...
def chart(width: int = ..., height: int = ..., illuminance_lux: float = ..., cct_k: float = ...,
          lamp_cd_m2: float = ..., background_cd_m2: float = ...) -> npt.NDArray[np.float32]: ...
def read_image(path: str) -> npt.NDArray[np.float32]: ...
def read_codes(path: str) -> npt.NDArray[Union[np.uint8, np.uint16]]: ...
def frame_buffer_cache(limit_bytes: Optional[int] = ..., free_stale: Optional[bool] = ...) -> dict: ...
