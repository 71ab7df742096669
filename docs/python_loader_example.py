#!/usr/bin/python3
"""A training-data loader loop with photosite's NightTransform (trains nothing): Cityscapes day
frames in, night raw frames + labels out, images per second printed.

    PYTHONPATH=build/python /usr/bin/python3 docs/python_loader_example.py --workers 2 --frames 8
"""
import argparse
import pathlib
import time

import torch

import photosite as ps
from photosite.torch import NightTransform

ROOT = pathlib.Path(__file__).resolve().parents[1]


class CityscapesNight(torch.utils.data.Dataset):
    def __init__(self, root, transform, limit):
        self.images = sorted((root / "leftImg8bit").glob("*_leftImg8bit.png"))[:limit]
        self.root, self.transform = root, transform

    def __len__(self):
        return len(self.images)

    def __getitem__(self, i):
        img = self.images[i]
        lab = self.root / "gtFine" / img.name.replace("_leftImg8bit.png", "_gtFine_labelIds.png")
        return self.transform((ps.read_codes(str(img)), ps.read_codes(str(lab))), index=i)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", default=str(ROOT / ".." / "shared" / "data" / "cityscapes"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--frames", type=int, default=8)
    a = ap.parse_args()
    ds = CityscapesNight(pathlib.Path(a.root), NightTransform(camera="onsemi-ar0331", seed=0, output="raw"), a.frames)
    if len(ds) == 0:
        raise SystemExit(f"no Cityscapes frames under {a.root}")
    dl = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=a.workers)
    t0 = time.perf_counter()
    n = 0
    for raw, labels in dl:  # a training step would go here
        n += raw.shape[0]
    dt = time.perf_counter() - t0
    print(f"{n} images in {dt:.1f} s: {n / dt:.2f} images/s ({a.workers} workers)")


if __name__ == "__main__":
    main()
