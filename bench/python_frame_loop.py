"""A frame loop of ps.night as a user writes it: wall time, process CPU, system time and minor page
faults per call (getrusage around each call; medians of 9 calls after a first one).

Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_frame_loop.py LABEL del|rebind [SHARED]
           [--image IMAGE --labels LABELS] [--cache-limit BYTES]
  del     `del r` before each call (the previous result's arrays freed first)
  rebind  `r = ps.night(...)` (the previous result freed after the new one is made)
SHARED: the folder holding data/cityscapes (default: ../shared beside the checkout).
--image, --labels: another frame (no instances) instead of aachen_000000 (scripts/resize_frame.py
makes one of another size); --cache-limit: ps.frame_buffer_cache(BYTES) before the loop.
The line also gives the peak resident set (ru_maxrss) and the cache's limit.
Prints one line: LABEL PATTERN wall MS cpu MS sys MS faults N peak MIB cache_limit BYTES held BYTES (what the
cache holds once the last result is freed). docs/python.md's
frame-buffer cache tables were measured with it (two builds' modules, alternately).
"""
import os
import resource
import statistics
import sys
import time

import photosite as ps


def main():
    args, opts = [], {}
    argv = sys.argv[1:]
    while argv:
        a = argv.pop(0)
        if a in ("--image", "--labels", "--cache-limit"):
            if not argv:
                sys.exit(f"python_frame_loop.py: {a} needs a value\n{__doc__}")
            opts[a] = argv.pop(0)
        else:
            args.append(a)
    if len(args) not in (2, 3) or args[1] not in ("del", "rebind") or (("--image" in opts) != ("--labels" in opts)):
        sys.exit(__doc__)
    label, pattern = args[0], args[1]
    if "--cache-limit" in opts:
        try:
            ps.frame_buffer_cache(int(opts["--cache-limit"]))
        except ValueError:
            sys.exit(f"python_frame_loop.py: --cache-limit {opts['--cache-limit']!r}: not an integer")
    if "--image" in opts:
        day, labels, inst = ps.read_codes(opts["--image"]), ps.read_codes(opts["--labels"]), None
    else:
        here = os.path.dirname(os.path.abspath(__file__))
        shared = args[2] if len(args) == 3 else os.path.join(here, "..", "..", "shared")
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
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    del r  # the last result freed: what the cache holds then (at most its limit)
    cache = ps.frame_buffer_cache()
    print(f"{label} {pattern} wall {m(walls):.1f} cpu {m(cpu):.1f} sys {m(sys_ms):.1f} faults {m(faults):.0f} "
          f"peak {peak_mib:.0f} MiB cache_limit {cache['limit_bytes']} held {cache['held_bytes']}")


if __name__ == "__main__":
    main()
