#!/usr/bin/python3
"""Two builds' dam break timed in turn in one run, one OpenMP thread: the step's phases (the app's summary timings,
which leave out start-up) as medians, and new / old pair by pair, old first in even pairs and new first in odd ones so
that a drift of the machine falls on both; and whether the two wrote the same pressure.csv byte for byte.

  bench/dambreak_pairs.py OLD_BUILD NEW_BUILD [--pairs 5] -- DAMBREAK_OPTIONS...
  e.g. bench/dambreak_pairs.py build/old build/release --pairs 5 -- --dim 3 --end-time 0.1 --frames 0

Prints one line per phase; run it on an idle machine.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

PHASES = ["total_s", "neighbors_s", "predict_s", "assemble_s", "solver_setup_s", "solve_s", "correct_s"]


def run(build, options, out):
    exe = Path(build) / "apps" / "dambreak" / "dambreak"
    proc = subprocess.run([str(exe), *options, "--out", str(out)], env=dict(os.environ, OMP_NUM_THREADS="1"),
                          capture_output=True, text=True)
    if not (out / "summary.json").exists():
        sys.exit(f"{exe} {' '.join(options)} wrote no summary (exit {proc.returncode}): {proc.stderr.strip()}")
    return json.loads((out / "summary.json").read_text())["timings"], (out / "pressure.csv").read_bytes()


def main():
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--pairs", type=int, default=5)
    a = ap.parse_args(argv[:split])
    options = argv[split + 1:]
    times = {"old": [], "new": []}
    same = True
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(a.pairs):
            order = [("old", a.old), ("new", a.new)] if k % 2 == 0 else [("new", a.new), ("old", a.old)]
            pressure = {}
            for tag, build in order:
                t, pressure[tag] = run(build, options, Path(tmp) / tag)
                times[tag].append(t)
            same = same and pressure["old"] == pressure["new"]
    print(f"dambreak {' '.join(options)}: {a.pairs} pairs, one thread")
    for phase in PHASES:
        old = [t.get(phase, 0.0) for t in times["old"]]
        new = [t.get(phase, 0.0) for t in times["new"]]
        ratios = [n / o for n, o in zip(new, old) if o > 0]
        if not ratios:
            continue
        print(f"{phase:15s} old {statistics.median(old):8.3f} s  new {statistics.median(new):8.3f} s  new/old "
              f"{statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})")
    print("pressure.csv byte for byte the same in every pair:", same)


if __name__ == "__main__":
    main()
