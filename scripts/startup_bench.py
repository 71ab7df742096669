#!/usr/bin/python3
"""Whole-process time and peak memory of two commands, run in turn (A B A B ...).

docs/benchmarks.md ("Thirteenth session", start-up) compares a command of this build with the same
command of an earlier build. Each run is started with subprocess and reaped with os.wait4, which
gives that child's own resource use: wall time (a monotonic clock around the run), user + system
CPU, and the peak resident set (ru_maxrss; a child forked from this small interpreter starts from
its size, about 10 MiB, so smaller peaks read as that floor). Pairing the runs keeps the ratio
meaningful when the machine's speed drifts. Prints min, median and max of each, and the median of
the pairs' ratios A/B.

Usage: scripts/startup_bench.py [-n RUNS] [--warmup W] -- 'COMMAND A' 'COMMAND B'
(each command one string, split as a shell splits words; environment variables as `env X=1 cmd`).
"""
import argparse
import os
import shlex
import statistics
import subprocess
import sys
import time


def run_once(argv):
    t0 = time.monotonic()
    p = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.monotonic() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        sys.exit(f"startup_bench.py: {' '.join(argv)} exited with {p.returncode}")
    return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", type=int, default=10, help="counted runs of each command (default 10)")
    ap.add_argument("--warmup", type=int, default=1, help="uncounted runs of each first (default 1)")
    ap.add_argument("a")
    ap.add_argument("b")
    o = ap.parse_args()
    if o.n < 1 or o.warmup < 0:
        sys.exit("startup_bench.py: -n must be at least 1 and --warmup at least 0")
    a, b = shlex.split(o.a), shlex.split(o.b)
    for _ in range(o.warmup):
        run_once(a), run_once(b)
    ra, rb = [], []
    for _ in range(o.n):
        ra.append(run_once(a))
        rb.append(run_once(b))
    print(f"{o.n} runs each, in turn; load average {os.getloadavg()[0]:.2f}")
    for name, rows in (("A", ra), ("B", rb)):
        for i, what, unit, scale in ((0, "wall", "ms", 1e3), (1, "cpu", "ms", 1e3), (2, "peak", "MiB", 1.0)):
            v = sorted(r[i] * scale for r in rows)
            print(f"{name} {what:5s} {v[0]:9.1f} {statistics.median(v):9.1f} {v[-1]:9.1f} {unit}  (min, median, max)")
    ratios = sorted(x[0] / y[0] for x, y in zip(ra, rb))
    print(f"A/B wall, median of the pairs: {statistics.median(ratios):.3f} ({ratios[0]:.3f} to {ratios[-1]:.3f})")
    print(f"A: {o.a}\nB: {o.b}")


if __name__ == "__main__":
    main()
