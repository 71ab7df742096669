"""The bundled presets (`photosite presets list` / `presets show --json`)."""
from __future__ import annotations

from typing import List

from . import _photosite


def cameras() -> List[str]:
    """Names of the bundled camera presets, sorted."""
    return _photosite.preset_names("camera")


def lenses() -> List[str]:
    """Names of the bundled lens presets, sorted."""
    return _photosite.preset_names("lens")


def scenes() -> List[str]:
    """Names of the bundled scene presets (presets/scenes), sorted."""
    return _photosite.preset_names("scene")


def rigs() -> List[str]:
    """Names of the bundled camera rigs (presets/rigs), sorted."""
    return _photosite.preset_names("rig")


def show(name: str) -> dict:
    """The resolved parameters of a camera, lens, scene or rig preset (name or .toml path): the
    same keys as `photosite presets show NAME --json`."""
    return _photosite.show_preset(name)
