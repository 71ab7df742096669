"""A frame loop of ps.night as a user writes it: wall time, process CPU, system time and minor page
faults per call (getrusage around each call; medians of 9 calls, or --calls N, after a first one).

Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_frame_loop.py LABEL del|rebind [SHARED]
           [--image IMAGE --labels LABELS] [--cache-limit BYTES] [--vary | --new-sizes] [--calls N]
  del     `del r` before each call (the previous result's arrays freed first)
  rebind  `r = ps.night(...)` (the previous result freed after the new one is made)
SHARED: the folder holding data/cityscapes (default: ../shared beside the checkout).
--image, --labels: another frame (no instances) instead of aachen_000000 (scripts/resize_frame.py
makes one of another size); --cache-limit: ps.frame_buffer_cache(BYTES) before the loop;
--vary: call k takes the frame less its last 8·(k mod 4) columns, so the size changes every call
and each size comes back every four (KITTI's frames differ by a few pixels); --new-sizes: call k
takes the frame less its last 8·k columns (every call a size not seen before, as in a data set of
mixed resolutions); what the cache holds of the sizes shows in the peak. --calls: time N calls
after the first (default 9).
Prints one line: LABEL PATTERN wall MS cpu MS sys MS faults N peak MIB cache_limit BYTES held BYTES
(the peak resident set, ru_maxrss; the cache's limit; what it holds once the last result is
freed). docs/python.md's frame-buffer cache tables were measured with it (two builds' modules,
alternately).
"""
import os
import resource
import statistics
import sys
import time

import numpy as np
import photosite as ps


def main():
    args, opts = [], {}
    argv = sys.argv[1:]
    while argv:
        a = argv.pop(0)
        if a in ("--vary", "--new-sizes"):
            opts[a] = True
        elif a in ("--image", "--labels", "--cache-limit", "--calls"):
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

    def frame(k):  # the inputs of call k
        cut = 8 * (k % 4) if "--vary" in opts else 8 * k if "--new-sizes" in opts else 0
        if cut == 0:
            return day, labels, inst
        crop = lambda a: None if a is None else np.ascontiguousarray(a[:, : a.shape[1] - cut])
        return crop(day), crop(labels), crop(inst)

    r = ps.night(*frame(0), camera=cam, exposure_s=0.02, seed=0, frame=0, backend="cpu")
    walls, cpu, sys_ms, faults = [], [], [], []
    try:
        calls = int(opts.get("--calls", 9))
    except ValueError:
        sys.exit(f"python_frame_loop.py: --calls {opts['--calls']!r}: not an integer")
    if calls < 1:
        sys.exit(f"python_frame_loop.py: --calls {calls}: must be 1 or more")
    for k in range(1, calls + 1):
        d, l, i = frame(k)
        if pattern == "del":
            del r
        a = resource.getrusage(resource.RUSAGE_SELF)
        t = time.perf_counter()
        r = ps.night(d, l, i, camera=cam, exposure_s=0.02, seed=0, frame=0, backend="cpu")
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
