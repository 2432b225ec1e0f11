#!/usr/bin/python3
"""Two builds' peak memory per particle, side by side in one run: the 2-D body-force channel of bench_scaling (3
warm-up steps, 5 timed) and the 3-D dam break (SPHERIC Test 2, its first 8 steps), as bench/phase_cost.py runs them,
one OpenMP thread, one process per run so that each peak RSS (getrusage / wait4) is that run's own. Memory is not
timing: one run per build and case is enough (reruns agreed within 1 MB). Time old against new with
bench/phase_pairs.py.

  bench/memory_pairs.py OLD_BUILD NEW_BUILD [--sizes 1e4,1e5,1e6] [--sizes3d 1e4,1e5] [--results bench/results]
  bench/memory_pairs.py --plot-only [--results bench/results]   # the chart again from memory_pairs.csv

Writes memory_pairs.csv (one row per build and case: peak RSS in MiB and bytes per particle of any kind, walls
included) and memory_pairs.png.
"""
import argparse
import csv
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from phase_cost import run, run_dambreak3d  # noqa: E402

GOAL_2D = 1500  # bytes per particle at 1e6 in 2-D (issue 40; the docs' KB is 1000 B)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old", nargs="?")
    ap.add_argument("new", nargs="?")
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="2-D fluid particle counts")
    ap.add_argument("--sizes3d", default="1e4,1e5", help="3-D fluid particle counts ('' for none)")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    if a.plot_only:
        with open(results / "memory_pairs.csv") as f:
            rows = list(csv.DictReader(f))
    else:
        if not (a.old and a.new):
            ap.error("give OLD_BUILD and NEW_BUILD, or --plot-only")
        rows = []
        cases = [(2, s) for s in a.sizes.split(",") if s] + [(3, s) for s in a.sizes3d.split(",") if s]
        for dim, size in cases:
            for label, build in (("old", a.old), ("new", a.new)):
                r = (run if dim == 2 else run_dambreak3d)(build, size, 1, "auto", False)[0]
                rows.append({"dim": dim, "size": size, "build": label, "build_dir": build,
                             "particles": r["particles"], "fluid": r["fluid"],
                             "peak_rss_mb": f"{float(r['peak_rss_mb']):.1f}",
                             "bytes_per_particle": f"{float(r['bytes_per_particle']):.0f}"})
                print(rows[-1], flush=True)
        with open(results / "memory_pairs.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, dim in zip(axes, ("2", "3")):
        sel = [r for r in rows if str(r["dim"]) == dim]
        sizes = list(dict.fromkeys(r["size"] for r in sel))
        for k, (label, colour) in enumerate((("old", "tab:grey"), ("new", "tab:blue"))):
            values = [next(float(r["bytes_per_particle"]) for r in sel if r["size"] == s and r["build"] == label)
                      for s in sizes]
            bars = ax.bar([i + (k - 0.5) * 0.38 for i in range(len(sizes))], values, 0.38, color=colour,
                          label=f"{label} build")
            ax.bar_label(bars, fmt="%.0f", fontsize=7)
        if dim == "2":
            ax.axhline(GOAL_2D, color="k", ls=":", lw=1, label="1.5 KB: issue 40's goal at 1e6")
        ax.set_xticks(range(len(sizes)), [f"{float(s):.0e} fluid" for s in sizes])
        ax.set_ylabel("peak RSS per particle [bytes]")
        ax.set_title("2-D body-force channel (bench_scaling)" if dim == "2" else "3-D dam break (SPHERIC Test 2)",
                     fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle("Peak memory per particle (walls included), one thread, default solver", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / "memory_pairs.png", dpi=120)
    print(f"wrote {results / 'memory_pairs.csv'} and {results / 'memory_pairs.png'}")


if __name__ == "__main__":
    main()
