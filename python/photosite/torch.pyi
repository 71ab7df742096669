from typing import Any, Dict, Optional, Tuple

import torch

class NightTransform:
    camera: str
    seed: int
    exposure_s: float
    output: str
    device_store: Optional[str]
    night_kwargs: Dict[str, Any]
    def __init__(self, camera: str = ..., seed: int = ..., exposure_s: float = ..., output: str = ...,
                 device_store: Optional[str] = ..., **night_kwargs: Any) -> None: ...
    def __call__(self, sample: Tuple[Any, Any], index: int = ...) -> Tuple[torch.Tensor, torch.Tensor]: ...
