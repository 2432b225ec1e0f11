#!/usr/bin/python3
"""Two builds' step phases timed in turn in one run: is the new build's step as fast as the old one's, phase by phase?
The body-force channel of bench_scaling (default solver, 3 warm-up steps, 5 timed), one OpenMP thread, the two
binaries alternating (old first in even pairs, new first in odd ones) so that a drift of the machine falls on both.
Reports per phase and size the median over pairs of old time / new time (>= 1: the new build is as fast or faster)
with its range, and the ratio of the two builds' fastest runs (noise only ever adds time, so the minima are the
steadier figure on a noisy machine). Run it on an idle machine.

  bench/phase_pairs.py OLD_BUILD NEW_BUILD [--sizes 1e4,1e5] [--pairs 7] [--steps 20] [--results bench/results]
                       [--stem phase_pairs]
  bench/phase_pairs.py --plot-only [--results bench/results] [--stem phase_pairs]   # again from STEM.csv

Writes STEM.csv (one row per run) and STEM.png (the ratios with their ranges); the stem names the comparison.
"""
import argparse
import csv
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

PHASES = ["neighbors_s", "predict_s", "assemble_s", "setup_s", "solve_s", "correct_s", "total_s"]


def run(build, size, steps):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scaling.csv"
        cmd = [str(Path(build) / "bench" / "bench_scaling"), "--sizes", size, "--solvers", "auto", "--cold", "",
               "--warmup", "3", "--steps", str(steps), "--out", str(out)]
        subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), check=True, capture_output=True)
        with open(out) as f:
            return list(csv.DictReader(f))[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old", nargs="?")
    ap.add_argument("new", nargs="?")
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--sizes", default="1e4,1e5")
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--stem", default="phase_pairs", help="the outputs' name: STEM.csv and STEM.png")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    if a.plot_only:
        with open(results / f"{a.stem}.csv") as f:
            rows = list(csv.DictReader(f))
        a.sizes = ",".join(dict.fromkeys(r["size"] for r in rows))
        a.pairs = 1 + max(int(r["pair"]) for r in rows)
        plot(rows, a, results)
        return
    if not (a.old and a.new):
        ap.error("give OLD_BUILD and NEW_BUILD (or --plot-only)")
    rows = []
    for size in a.sizes.split(","):
        for k in range(a.pairs):
            order = [("old", a.old), ("new", a.new)] if k % 2 == 0 else [("new", a.new), ("old", a.old)]
            for name, build in order:
                r = run(build, size, a.steps)
                rows.append({"build": name, "pair": k, "size": size, **{ph: r[ph] for ph in PHASES},
                             "fluid": r["fluid"], "iterations": r["iterations"]})
            print(size, k, flush=True)
    with open(results / f"{a.stem}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, a, results)


def plot(rows, a, results):
    fig, ax = plt.subplots(figsize=(9, 4))
    highest = 1.35
    sizes = a.sizes.split(",")
    width = 0.8 / len(sizes)
    print(f"{'size':>6} " + " ".join(f"{ph[:-2]:>28}" for ph in PHASES))
    for s_index, size in enumerate(sizes):
        line = []
        for p_index, ph in enumerate(PHASES):
            ratios = []
            for k in range(a.pairs):
                old = [float(r[ph]) for r in rows if r["size"] == size and int(r["pair"]) == k and r["build"] == "old"][0]
                new = [float(r[ph]) for r in rows if r["size"] == size and int(r["pair"]) == k and r["build"] == "new"][0]
                ratios.append(old / new if new > 0 else float("nan"))
            med = statistics.median(ratios)
            fastest = min(float(r[ph]) for r in rows if r["size"] == size and r["build"] == "old") / min(
                float(r[ph]) for r in rows if r["size"] == size and r["build"] == "new")
            line.append(f"{med:.3f} ({min(ratios):.2f}-{max(ratios):.2f}) min {fastest:.3f}")
            ax.plot(p_index + (s_index - (len(sizes) - 1) / 2) * width, fastest, "kD", ms=5,
                    label="fastest old / fastest new" if p_index == 0 and s_index == 0 else None)
            x = p_index + (s_index - (len(sizes) - 1) / 2) * width
            ax.bar(x, med, width, color=f"C{s_index}", label=f"{float(size):.0e} particles" if p_index == 0 else None)
            ax.errorbar(x, med, yerr=[[med - min(ratios)], [max(ratios) - med]], color="k", capsize=3, lw=1)
            highest = max(highest, max(ratios) + 0.05, fastest + 0.05)
        print(f"{size:>6} " + " ".join(f"{c:>28}" for c in line))
    ax.axhline(1.0, color="grey", lw=1)
    ax.axhline(0.97, color="red", ls=":", lw=1)
    ax.text(len(PHASES) - 0.5, 0.97, "0.97", color="red", fontsize=7, va="top", ha="right")
    ax.set_xticks(range(len(PHASES)), [ph[:-2] for ph in PHASES])
    ax.set_ylim(0.7, highest)
    ax.set_ylabel("old time / new time (median of pairs, range)")
    ax.set_title(f"Body-force channel, one thread, {a.steps} steps: {a.pairs} pairs, old and new in turn", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / f"{a.stem}.png", dpi=120)


if __name__ == "__main__":
    main()
