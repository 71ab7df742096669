#!/usr/bin/python3
"""`photosite bench python`: the Python module's costs, measured in one run on one machine.

1. Overhead of `photosite.night` from Python against the C++ chain in the same process, at
   2048x1024: the wall time of the Python call against NightResult.chain_ms, the library chain's
   own time inside that call (labels decode, linearize .. sensor frame). The difference is what
   the binding adds: argument checks, the input copy / code conversion, wrapping the outputs.
2. Images per second through a torch DataLoader (NightTransform) with 1 and 2 workers, against
   the CLI + files route (`photosite night` per frame writing an EXR, read back with read_exr).

Writes bench_python.csv and bench_python.png to docs/ (or --out-dir). Frames: the shared
Cityscapes frames (../shared/data/cityscapes) when present, else the bundled KITTI frame resized
to 2048x1024 (nearest).
"""
import argparse
import csv
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import photosite as ps

ROOT = pathlib.Path(__file__).resolve().parents[1]


def machine():
    model = "unknown CPU"
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    return f"{model}, {os.cpu_count()} hardware threads"


def frames_list(n):
    city = ROOT / ".." / "shared" / "data" / "cityscapes"
    left = sorted((city / "leftImg8bit").glob("*_leftImg8bit.png"))
    pairs = []
    for img in left:
        lab = city / "gtFine" / img.name.replace("_leftImg8bit.png", "_gtFine_labelIds.png")
        if lab.exists():
            pairs.append((str(img), str(lab)))
    if pairs:
        return "cityscapes", (pairs * n)[:n]
    return "kitti", [(str(ROOT / "samples/kitti/image_2/000000_10.png"),
                      str(ROOT / "samples/kitti/semantic/000000_10.png"))] * n


def load(pair, size=(1024, 2048)):
    day, lab = ps.read_codes(pair[0]), ps.read_codes(pair[1])
    if day.shape[:2] != size:  # nearest resize of the KITTI fallback to the benchmark size
        yi = (np.arange(size[0]) * day.shape[0] // size[0])
        xi = (np.arange(size[1]) * day.shape[1] // size[1])
        day = np.ascontiguousarray(day[yi][:, xi])
        lab = np.ascontiguousarray(lab[yi][:, xi])
    return day, lab


def overhead(pair, repeats, store):
    day, lab = load(pair)
    cam = ps.Camera("onsemi-ar0331", device_store=store)
    ps.night(day, lab, camera=cam, backend="cpu")  # warm-up: device maps, caches
    walls, chains = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = ps.night(day, lab, camera=cam, backend="cpu")
        walls.append((time.perf_counter() - t0) * 1e3)
        chains.append(r.chain_ms)
    return statistics.median(walls), statistics.median(chains), day.shape


def loader_rate(pairs, workers, store):
    import torch
    from photosite.torch import NightTransform

    class DS(torch.utils.data.Dataset):
        def __init__(self):
            self.t = NightTransform(camera="onsemi-ar0331", seed=1, output="raw", device_store=store, backend="cpu")

        def __len__(self):
            return len(pairs)

        def __getitem__(self, i):
            return self.t(load(pairs[i]), index=i)

    dl = torch.utils.data.DataLoader(DS(), batch_size=None, num_workers=workers)
    t0 = time.perf_counter()
    n = sum(1 for _ in dl)
    return n / (time.perf_counter() - t0)


def cli_rate(pairs, exe, store):
    env = dict(os.environ, PHOTOSITE_DEVICE_STORE=store)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        for i, (img, lab) in enumerate(pairs):
            out = os.path.join(d, f"n{i}.exr")
            subprocess.run([exe, "night", "--image", img, "--labels", lab, "--seed", "1", "--backend", "cpu",
                            "--layers", "raw,labels", "--out", out], check=True, capture_output=True, env=env)
            ch, _, _ = ps.read_exr(out)
            _ = ch["raw.Y"], ch["labels.Y"]
    return len(pairs) / (time.perf_counter() - t0)


def count(text):
    """A count of at least 1 (argparse reports anything else as a usage error, exit 2)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number")
    if n < 1:
        raise argparse.ArgumentTypeError(f"{n} is not allowed: must be at least 1")
    return n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--photosite", required=True)
    ap.add_argument("--frames", type=count, default=4)
    ap.add_argument("--repeats", type=count, default=3)
    ap.add_argument("--out-dir", default=str(ROOT / "docs"))
    a = ap.parse_args()
    # Checked before the work, as `photosite bench` checks every target's --out-dir.
    if not os.path.isdir(a.out_dir):
        ap.error(f"--out-dir: {a.out_dir}: output folder does not exist (the bench does not create it)")
    # The fixed-pattern maps the runs make go to a store of this run's own, removed at the end
    # (also when the run fails).
    with tempfile.TemporaryDirectory(prefix="photosite-bench-store-") as store:
        run(a, store)


def run(a, store):
    source, pairs = frames_list(a.frames)
    wall, chain, shape = overhead(pairs[0], a.repeats, store)
    ov = (wall - chain) / chain * 100
    print(f"night {shape[1]}x{shape[0]} ({source}): Python {wall:.1f} ms, C++ chain {chain:.1f} ms, "
          f"overhead {ov:.2f}% (target <= 5%)")
    rates = {}
    for w in (1, 2):
        rates[f"DataLoader, {w} worker{'s' if w > 1 else ''}"] = loader_rate(pairs, w, store)
    rates["CLI + EXR files"] = cli_rate(pairs, a.photosite, store)
    for k, v in rates.items():
        print(f"{k}: {v:.3f} images/s")
    out = pathlib.Path(a.out_dir)
    csv_path = out / "bench_python.csv"
    with open(csv_path, "w", newline="") as f:
        f.write(f"# photosite bench python; {machine()}; {source} frames {shape[1]}x{shape[0]}; backend cpu\n")
        w = csv.writer(f)
        w.writerow(["measure", "value", "unit", "ratio_to_peer", "peer"])
        w.writerow(["night from Python", f"{wall:.2f}", "ms", f"{wall / chain:.4f}", "C++ chain in the same call"])
        w.writerow(["C++ chain", f"{chain:.2f}", "ms", "1", ""])
        w.writerow(["overhead", f"{ov:.3f}", "%", "", "target <= 5"])
        cli = rates["CLI + EXR files"]
        for k, v in rates.items():
            w.writerow([k, f"{v:.4f}", "images/s", f"{v / cli:.3f}", "CLI + EXR files"])
    print(csv_path)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.bar(["C++ chain", "ps.night()"], [chain, wall], color=["#888", "#3a7"])
    ax1.set_ylabel(f"ms per {shape[1]}x{shape[0]} frame (median of {a.repeats})")
    ax1.set_title(f"Python overhead: {ov:.2f}% (target <= 5%)")
    ax2.bar(list(rates), list(rates.values()), color=["#3a7", "#2a5", "#888"])
    ax2.set_ylabel("images / s")
    ax2.set_title(f"{len(pairs)} {source} frames, night -> raw + labels")
    ax2.tick_params(axis="x", labelsize=8)
    fig.suptitle(f"photosite bench python ({machine()})", fontsize=9)
    fig.tight_layout()
    png = out / "bench_python.png"
    fig.savefig(png, dpi=110)
    print(png)


if __name__ == "__main__":
    main()
