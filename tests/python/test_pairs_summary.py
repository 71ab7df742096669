"""bench/pairs_summary.py (scripts/bench_pairs.sh's summary) on hand-made `bench night` tables whose
medians and pair counts are known."""
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "bench" / "pairs_summary.py"


def table(chain_ms, chain_x, sensor_ms, sensor_x):
    # The layout bench night prints: a header, then "stage  ms  x peer" rows.
    return ("photosite bench night: frame, 2048x1024, 2 threads, median of 9\nmachine: test\n\n"
            f"{'stage':<36s} {'ms':>10s} {'x peer':>12s}\n"
            f"{'whole chain':<36s} {chain_ms:10.2f} {chain_x:12.2f}\n"
            f"{'sensor (expose)':<36s} {sensor_ms:10.2f} {sensor_x:12.2f}\n"
            "\ntargets: whole chain <= 50 ms: no\n")


def run(d):
    return subprocess.run([sys.executable, str(SCRIPT), str(d)], capture_output=True, text=True)


def row(out, stage):
    line = next(l for l in out.splitlines() if l.startswith(stage))
    return line[len(stage):].split()


def test_medians_and_pairs_lower(tmp_path):
    before = [(90, 7.0, 30, 2.0), (100, 7.5, 35, 2.5), (80, 6.0, 40, 3.0)]
    after = [(85, 7.1, 31, 1.9), (95, 7.4, 36, 2.4), (82, 5.9, 39, 2.9)]
    for k, (a, b) in enumerate(zip(before, after), 1):
        (tmp_path / f"a_{k}.txt").write_text(table(*a))
        (tmp_path / f"b_{k}.txt").write_text(table(*b))
    # A tenth pair: a_10 is paired with b_10 (runs are matched by their number).
    (tmp_path / "a_10.txt").write_text(table(70, 5.0, 30, 2.0))
    (tmp_path / "b_10.txt").write_text(table(71, 5.1, 29, 1.9))
    r = run(tmp_path)
    assert r.returncode == 0, r.stderr
    assert "pairs: 4" in r.stdout
    chain = row(r.stdout, "whole chain")
    assert chain[:4] == ["85.00", "6.50", "83.50", "6.50"]  # medians of 70,80,90,100 / 71,82,85,95
    assert chain[4:] == ["2/4", "2/4"]                       # ms lower in pairs 1, 2; ratio in 2, 3
    sensor = row(r.stdout, "sensor (expose)")
    assert sensor[4:] == ["2/4", "4/4"]


def test_unmatched_runs_are_refused(tmp_path):
    (tmp_path / "a_1.txt").write_text(table(90, 7.0, 30, 2.0))
    r = run(tmp_path)
    assert r.returncode != 0 and "1 before and 0 after" in (r.stderr + r.stdout)
