#!/usr/bin/python3
"""Two builds' distributed step timed in turn in one run: the dam break of bench_distributed_step on P ranks (one
OpenMP thread each), the two binaries alternating (old first in even pairs, new first in odd ones) so that a drift of
the machine falls on both. Reports per phase the median over pairs of old time / new time (>= 1: the new build is as
fast or faster) with its range. Run it on an idle machine.

  bench/rank_pairs.py OLD_BUILD NEW_BUILD [--dim 2] [--fluid 1e6] [--steps 20] [--ranks 2] [--pairs 3]
                      [--results bench/results] [--stem rank_pairs_2d]

Writes STEM.csv: bench_distributed_step's row of each run with the build ("old" or "new") and the pair in front.
"""
import argparse
import csv
import os
import statistics
import subprocess
import tempfile

PHASES = ["step_s", "neighbors_s", "predict_s", "assemble_s", "setup_s", "solve_s", "correct_s"]


def run(build, args, out):
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    command = ["mpirun", "--oversubscribe", "-np", str(args.ranks), os.path.join(build, "bench", "bench_distributed_step"),
               "--dim", str(args.dim), "--fluid", args.fluid, "--steps", str(args.steps), "--solver", args.solver,
               "--out", out]
    print(" ".join(command), flush=True)
    subprocess.run(command, env=env, check=True, stdout=subprocess.DEVNULL)
    with open(out, newline="") as f:
        return list(csv.DictReader(f))[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--dim", type=int, default=2)
    parser.add_argument("--fluid", default="1e6")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--pairs", type=int, default=3)
    parser.add_argument("--solver", default="auto")
    parser.add_argument("--results", default="bench/results")
    parser.add_argument("--stem", default="rank_pairs_2d")
    args = parser.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for pair in range(args.pairs):
            order = ["old", "new"] if pair % 2 == 0 else ["new", "old"]
            for build in order:
                out = os.path.join(scratch, f"{build}{pair}.csv")
                rows.append(dict(build=build, pair=pair, **run(getattr(args, build), args, out)))
    with open(os.path.join(args.results, args.stem + ".csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)

    print(f"{'phase':<12} {'old s':>8} {'new s':>8}  old/new median (range over {args.pairs} pairs)")
    for phase in PHASES:
        old = [float(r[phase]) for r in rows if r["build"] == "old"]
        new = [float(r[phase]) for r in rows if r["build"] == "new"]
        ratios = [o / n for o, n in zip(old, new) if n > 0]
        if not ratios:
            continue
        print(f"{phase:<12} {statistics.median(old):8.3f} {statistics.median(new):8.3f}  "
              f"{statistics.median(ratios):.3f} ({min(ratios):.3f}-{max(ratios):.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
