"""Fixtures for the Python module's tests: the built `photosite` binary (the CLI the module must
agree with), a private device store and the bundled KITTI sample."""
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("PHOTOSITE_BUILD_DIR", ROOT / "build"))
KITTI_IMAGE = ROOT / "samples/kitti/image_2/000000_10.png"
KITTI_LABELS = ROOT / "samples/kitti/semantic/000000_10.png"
CITYSCAPES = ROOT / ".." / "shared" / "data" / "cityscapes"


@pytest.fixture(scope="session")
def store(tmp_path_factory):
    """A device store of our own, shared by the module and the CLI runs of one session."""
    d = tmp_path_factory.mktemp("device-store")
    os.environ["PHOTOSITE_DEVICE_STORE"] = str(d)
    return str(d)


@pytest.fixture(scope="session")
def cli(store):
    """Runs the built photosite binary; returns CompletedProcess (text)."""
    exe = BUILD / "photosite"
    if not exe.exists():
        pytest.fail(f"{exe} is missing: build the photosite target first (scripts/setup.sh)")

    def run(*args, check=True):
        env = dict(os.environ, PHOTOSITE_DEVICE_STORE=store)
        r = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, env=env)
        if check and r.returncode != 0:
            raise AssertionError(f"photosite {' '.join(map(str, args))} failed ({r.returncode}):\n{r.stderr}")
        return r

    return run


def cityscapes_frames():
    """(image, labelIds, instanceIds) paths of the shared Cityscapes frames, sorted."""
    left = sorted((CITYSCAPES / "leftImg8bit").glob("*_leftImg8bit.png"))
    out = []
    for img in left:
        stem = img.name.replace("_leftImg8bit.png", "")
        lab = CITYSCAPES / "gtFine" / f"{stem}_gtFine_labelIds.png"
        inst = CITYSCAPES / "gtFine" / f"{stem}_gtFine_instanceIds.png"
        if lab.exists():
            out.append((img, lab, inst if inst.exists() else None))
    return out
