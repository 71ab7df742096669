"""Summary of scripts/bench_pairs.sh's runs: per stage of `photosite bench night`, the median ms and
the median ratio to the run's own peer on each side, and in how many pairs the after run (b_K)
took fewer ms / had the lower ratio than the before run (a_K) of the same pair.

Usage: /usr/bin/python3 bench/pairs_summary.py OUT_DIR
"""
import glob
import os
import re
import statistics
import sys

LINE = re.compile(r"^(.+?)\s+([0-9.]+)\s+([0-9.]+)\s*$")


def parse(path):
    """The stage table of one `bench night` output: stage -> (ms, ratio to the peer)."""
    out = {}
    with open(path) as f:
        for line in f:
            m = LINE.match(line)
            if m and not line.startswith("stage"):
                out[m.group(1).strip()] = (float(m.group(2)), float(m.group(3)))
    return out


def runs(d, side):
    paths = glob.glob(os.path.join(d, f"{side}_*.txt"))
    paths.sort(key=lambda p: int(re.search(r"_(\d+)\.txt$", p).group(1)))
    return [parse(p) for p in paths]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    a, b = runs(sys.argv[1], "a"), runs(sys.argv[1], "b")
    if not a or len(a) != len(b) or not all(a) or not all(b):
        sys.exit(f"pairs_summary.py: {sys.argv[1]}: {len(a)} before and {len(b)} after runs, or a run without its table")
    print(f"pairs: {len(a)}")
    print(f"{'stage':44s} {'before ms':>9s} {'x':>5s} {'after ms':>9s} {'x':>5s} {'ms lower':>8s} {'x lower':>7s}")
    for k in a[0]:
        if not all(k in r for r in a + b):
            continue
        ra, rb = [r[k] for r in a], [r[k] for r in b]
        fewer = sum(1 for x, y in zip(ra, rb) if y[0] < x[0])
        lower = sum(1 for x, y in zip(ra, rb) if y[1] < x[1])
        print(f"{k:44s} {statistics.median(x[0] for x in ra):9.2f} {statistics.median(x[1] for x in ra):5.2f} "
              f"{statistics.median(x[0] for x in rb):9.2f} {statistics.median(x[1] for x in rb):5.2f} "
              f"{fewer:5d}/{len(ra):<2d} {lower:4d}/{len(ra):<2d}")


if __name__ == "__main__":
    main()
