"""photosite.torch.NightTransform: picklable, deterministic per (seed, index), and a real
DataLoader with 2 worker processes gives exactly the single-process results."""
import pickle
import warnings

import numpy as np
import pytest

import photosite as ps
from conftest import KITTI_IMAGE, KITTI_LABELS, cityscapes_frames

torch = pytest.importorskip("torch")
from photosite.torch import NightTransform  # noqa: E402


class PairDataset(torch.utils.data.Dataset):
    """(day image, labelIds) pairs from files, through a NightTransform keyed by the index."""

    def __init__(self, pairs, transform):
        self.pairs, self.transform = pairs, transform

    def __len__(self):
        return len(self.pairs)

    def __getitem__(self, i):
        img, lab = self.pairs[i]
        return self.transform((ps.read_codes(str(img)), ps.read_codes(str(lab))), index=i)


def run_loader(ds, workers):
    dl = torch.utils.data.DataLoader(ds, batch_size=None, num_workers=workers, shuffle=False)
    return [(x.clone(), y.clone()) for x, y in dl]


def test_transform_pickles_and_is_deterministic(store):
    t = NightTransform(camera="sony-icx267-flea2", seed=11, device_store=store)
    day, lab = ps.read_codes(str(KITTI_IMAGE)), ps.read_codes(str(KITTI_LABELS))
    a, ya = t((day, lab), index=3)
    t2 = pickle.loads(pickle.dumps(t))
    b, yb = t2((day, lab), index=3)
    assert torch.equal(a, b) and torch.equal(ya, yb)
    c, _ = t((day, lab), index=4)
    assert not torch.equal(a, c)  # another index, another noise draw
    assert a.shape == (3, *lab.shape) and a.dtype == torch.float32 and 0 <= a.min() and a.max() <= 1
    assert ya.dtype == torch.int64
    # tensors in (3 x H x W uint8 image, H x W labels) give the same result as arrays
    d, _ = t((torch.from_numpy(day).permute(2, 0, 1), torch.from_numpy(lab)), index=3)
    assert torch.equal(a, d)


def test_dataloader_two_workers_equal_single_process_kitti(store):
    pairs = [(KITTI_IMAGE, KITTI_LABELS)] * 3
    ds = PairDataset(pairs, NightTransform(camera="sony-icx267-flea2", seed=5, output="raw", device_store=store))
    one = run_loader(ds, 0)
    two = run_loader(ds, 2)
    for (x1, y1), (x2, y2) in zip(one, two):
        assert torch.equal(x1, x2) and torch.equal(y1, y2)
    assert not torch.equal(one[0][0], one[1][0])  # per-index seeds differ


def test_dataloader_two_workers_cityscapes(store):
    frames = cityscapes_frames()
    if not frames:
        warnings.warn("SKIPPED LOUDLY: ../shared/data/cityscapes is missing; the Cityscapes DataLoader test did not run")
        pytest.skip("../shared/data/cityscapes not found (shared data set missing)")
    pairs = [(img, lab) for img, lab, _ in frames[:4]]
    ds = PairDataset(pairs, NightTransform(camera="onsemi-ar0331", seed=2, device_store=store))
    one = run_loader(ds, 0)
    two = run_loader(ds, 2)
    assert len(one) == len(pairs)
    for (x1, y1), (x2, y2) in zip(one, two):
        assert x1.shape == (3, 1024, 2048)
        assert torch.equal(x1, x2) and torch.equal(y1, y2)


@pytest.mark.parametrize("value", [65536 + 7, -1])
def test_transform_refuses_label_values_outside_uint16(value, store):
    # Checked before the cast to uint16: 65543 would wrap to 7 (road), -1 to 65535.
    t = NightTransform(camera="sony-icx267-flea2", seed=7, device_store=store)
    day, lab = ps.read_codes(str(KITTI_IMAGE)), ps.read_codes(str(KITTI_LABELS)).astype(np.int64)
    lab[2, 5] = value
    with pytest.raises(ValueError, match=rf"labels: value {value} at pixel \(5, 2\) is not a label id in 0..65535"):
        t((day, torch.from_numpy(lab)), index=0)


def test_transform_needs_the_index_and_sRGB_codes(store):
    """Without the sample's index every sample of a size would share one noise field; a float
    image (torchvision's ToTensor output, sRGB in [0, 1]) would be read as linear."""
    t = NightTransform(camera="sony-icx267-flea2", seed=3, device_store=store)
    day, lab = ps.read_codes(str(KITTI_IMAGE)), ps.read_codes(str(KITTI_LABELS))
    with pytest.raises(TypeError, match="index: expected the sample's int index, got nothing"):
        t((day, lab))
    with pytest.raises(TypeError, match="index: expected the sample's int index, got ndarray"):
        t(day, lab)  # the torchvision call t(image, target)
    with pytest.raises(ValueError, match="image: expected 8- or 16-bit sRGB codes"):
        t((day.astype(np.float32) / 255, lab), index=0)
    img, _ = t((day, lab), index=np.int64(2))  # a NumPy integer index is an index
    assert img.shape[0] == 3


def test_transform_names_a_bad_seed_or_exposure():
    """A float seed was truncated by int() (1.5 ran as 1) and a str exposure raised float()'s own
    message, which names no argument: both are TypeErrors naming the argument, as in ps.night."""
    with pytest.raises(TypeError, match="seed: expected an int, got float"):
        NightTransform(seed=1.5)
    with pytest.raises(TypeError, match="exposure_s: expected a number of seconds, got str"):
        NightTransform(exposure_s="x")
    assert NightTransform(seed=np.int64(3), exposure_s=np.float32(0.01)).seed == 3
