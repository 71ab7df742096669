"""A frame loop of ps.night as a user writes it: wall time, process CPU, system time and minor page
faults per call (getrusage around each call; medians of 9 calls after a first one).

Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_frame_loop.py LABEL del|rebind [SHARED]
  del     `del r` before each call (the previous result's arrays freed first)
  rebind  `r = ps.night(...)` (the previous result freed after the new one is made)
SHARED: the folder holding data/cityscapes (default: ../shared beside the checkout).
Prints one line: LABEL PATTERN wall MS cpu MS sys MS faults N. docs/python.md's frame-buffer cache
tables were measured with it (two builds' modules, alternately).
"""
import os
import resource
import statistics
import sys
import time

import photosite as ps


def main():
    if len(sys.argv) not in (3, 4) or sys.argv[2] not in ("del", "rebind"):
        sys.exit(__doc__)
    label, pattern = sys.argv[1], sys.argv[2]
    here = os.path.dirname(os.path.abspath(__file__))
    shared = sys.argv[3] if len(sys.argv) == 4 else os.path.join(here, "..", "..", "shared")
    city = os.path.join(shared, "data", "cityscapes")
    if not os.path.isdir(city):
        sys.exit(f"python_frame_loop.py: {city}: no Cityscapes folder (give SHARED)")
    day = ps.read_codes(f"{city}/leftImg8bit/aachen_000000_000019_leftImg8bit.png")
    labels = ps.read_codes(f"{city}/gtFine/aachen_000000_000019_gtFine_labelIds.png")
    inst = ps.read_codes(f"{city}/gtFine/aachen_000000_000019_gtFine_instanceIds.png")
    cam = ps.Camera("onsemi-ar0331")
    r = ps.night(day, labels, inst, camera=cam, exposure_s=0.02, seed=0, frame=0, backend="cpu")
    walls, cpu, sys_ms, faults = [], [], [], []
    for _ in range(9):
        if pattern == "del":
            del r
        a = resource.getrusage(resource.RUSAGE_SELF)
        t = time.perf_counter()
        r = ps.night(day, labels, inst, camera=cam, exposure_s=0.02, seed=0, frame=0, backend="cpu")
        b = resource.getrusage(resource.RUSAGE_SELF)
        walls.append((time.perf_counter() - t) * 1e3)
        cpu.append((b.ru_utime - a.ru_utime + b.ru_stime - a.ru_stime) * 1e3)
        sys_ms.append((b.ru_stime - a.ru_stime) * 1e3)
        faults.append(b.ru_minflt - a.ru_minflt)
    m = statistics.median
    print(f"{label} {pattern} wall {m(walls):.1f} cpu {m(cpu):.1f} sys {m(sys_ms):.1f} faults {m(faults):.0f}")


if __name__ == "__main__":
    main()
