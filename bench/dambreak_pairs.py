#!/usr/bin/python3
"""Two builds' dam break timed in turn in one run, one OpenMP thread: the step's phases (the app's summary timings,
which leave out start-up) as medians, and new / old pair by pair, old first in even pairs and new first in odd ones so
that a drift of the machine falls on both; and whether the two wrote the same pressure.csv byte for byte.

  bench/dambreak_pairs.py OLD_BUILD NEW_BUILD [--pairs 5] [--stem NAME [--results DIR] [--names OLD,NEW]]
                          -- DAMBREAK_OPTIONS...
  e.g. bench/dambreak_pairs.py build/old build/release --pairs 5 -- --dim 3 --end-time 0.1 --frames 0

Prints one line per phase; with --stem also writes DIR/NAME.csv (every run's phases) and DIR/NAME.png (new / old per
phase, median and range). Run it on an idle machine.
"""
import argparse
import csv
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
    ap.add_argument("--stem", help="write RESULTS/STEM.csv and .png")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--names", help="OLD,NEW: what the chart calls the builds (default: their paths)")
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
    summary = []
    for phase in PHASES:
        old = [t.get(phase, 0.0) for t in times["old"]]
        new = [t.get(phase, 0.0) for t in times["new"]]
        ratios = [n / o for n, o in zip(new, old) if o > 0]
        if not ratios:
            continue
        summary.append((phase, statistics.median(ratios), min(ratios), max(ratios)))
        print(f"{phase:15s} old {statistics.median(old):8.3f} s  new {statistics.median(new):8.3f} s  new/old "
              f"{statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})")
    print("pressure.csv byte for byte the same in every pair:", same)
    if a.stem:
        old_name, new_name = a.names.split(",") if a.names else (a.old, a.new)
        write_results(Path(a.results), a.stem, options, old_name, new_name, times, summary, same)


def write_results(results, stem, options, old_build, new_build, times, summary, same):
    results.mkdir(parents=True, exist_ok=True)
    with open(results / f"{stem}.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["build", "pair", *PHASES])
        for tag in ("old", "new"):
            for k, t in enumerate(times[tag]):
                w.writerow([tag, k, *(f"{t.get(p, 0.0):.6g}" for p in PHASES)])
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.6))
    names = [p[:-2] for p, *_ in summary]
    med = [m for _, m, _, _ in summary]
    err = [[m - lo for _, m, lo, _ in summary], [hi - m for _, m, _, hi in summary]]
    ax.bar(names, med, yerr=err, capsize=3, color="tab:blue")
    ax.axhline(1.0, color="k", lw=0.8)
    for x, m in enumerate(med):
        ax.text(x, m + 0.02, f"{m:.3f}", ha="center", va="bottom", fontsize=8)
    ax.set_ylabel("new / old time (median, range)")
    ax.set_title(f"dambreak {' '.join(options)}\n{new_build} against {old_build}, "
                 f"{len(times['old'])} pairs, one thread; pressure.csv the same: {same}", fontsize=8)
    ax.tick_params(axis="x", labelsize=8)
    fig.tight_layout()
    fig.savefig(results / f"{stem}.png", dpi=120)


if __name__ == "__main__":
    main()
