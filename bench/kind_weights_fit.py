#!/usr/bin/python3
"""What a fluid and a boundary (wall or dummy) particle cost each phase of the 3-D step, fitted from each rank's own
phase times, and the kind weights for the cuts that follow (docs/scaling.md). Runs the 3-D dam break of
bench_distributed_step on 2 ranks (one thread each, one run at a time) once per weight set, each cut giving the ranks
other mixes of kinds, and fits each phase's seconds per step on a rank as c_fluid n_fluid + c_boundary (n_wall +
n_dummy) (non-negative least squares over every rank of every run; this tank's cuts give every rank walls and
dummies in nearly one ratio). A phase that ends in a collective holds the wait for the slower rank, so the weights
follow from the neighbour phase and the predictor, which end in none; the others are reported beside them.
Run it on an idle machine.

  bench/kind_weights_fit.py BUILD [--fluid 4.3e5] [--steps 6] [--solver auto] [--rounds 0]
                            [--weights "1 0.6 0.25 0.01" "1 0.1 0.02 0.01" ...] [--results bench/results]
                            [--stem kind_weights_fit_3d] [--refit]

With --rounds R the weight sets run R times, in reverse order every other round, each round after a run on one rank,
and the step's speed-up on 2 ranks over that round's one-rank run is printed per weight set and round.
Writes STEM.csv (a row per rank per run: the round, the weights, the counts by kind, each phase's seconds per step,
the step's, and the one-rank run's step) and STEM_costs.csv (each phase's fitted nanoseconds per fluid and per
boundary particle and step, and the fit's largest residual); --refit fits STEM.csv again without running.
"""
import argparse
import csv
import os
import re
import subprocess
import tempfile

import numpy as np
from scipy.optimize import nnls

PHASES = ["neighbours", "predict", "assemble", "AMG setup", "solve", "correct"]
LINE = re.compile(r"rank (\d+) owns (\d+) particles, (\d+) fluid, (\d+) wall, (\d+) dummy, (\d+) ghost: "
                  r"(.*) s per step")


def run(build, args, weights, out, ranks=2):
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    command = ["mpirun", "--oversubscribe", "-np", str(ranks), os.path.join(build, "bench", "bench_distributed_step"),
               "--dim", "3", "--fluid", args.fluid, "--steps", str(args.steps), "--solver", args.solver, "--per-rank",
               "--kind-weights", *weights.split(), "--out", out]
    print(" ".join(command), flush=True)
    done = subprocess.run(command, env=env, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rows = []
    for line in done.stderr.splitlines():
        m = LINE.search(line)
        if not m:
            continue
        phases = {name.strip(): value for name, value in re.findall(r"([A-Za-z ]+?) ([0-9.]+)", m.group(7))}
        rows.append(dict(ranks=ranks, weights=weights, rank=int(m.group(1)), particles=int(m.group(2)),
                         fluid=int(m.group(3)),
                         wall=int(m.group(4)), dummy=int(m.group(5)),
                         **{p: float(phases[p]) for p in PHASES}))
    if len(rows) != ranks:
        raise SystemExit(f"expected a line from each of {ranks} ranks:\n" + done.stderr)
    with open(out, newline="") as f:
        step = float(list(csv.DictReader(f))[-1]["step_s"])
    for r in rows:
        r["step_s"] = step
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("--fluid", default="4.3e5")
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--solver", default="auto")
    parser.add_argument("--rounds", type=int, default=0, help="rounds with a one-rank run each (0: no one-rank run)")
    parser.add_argument("--weights", nargs="+",
                        default=["1 0.6 0.25 0.01", "1 0.1 0.02 0.01", "1 1 1 1", "1 0.3 0.1 0.01"])
    parser.add_argument("--results", default="bench/results")
    parser.add_argument("--stem", default="kind_weights_fit_3d")
    parser.add_argument("--refit", action="store_true", help="fit STEM.csv again without running")
    args = parser.parse_args()

    rows = []
    if args.refit:
        with open(os.path.join(args.results, args.stem + ".csv"), newline="") as f:
            rows = list(csv.DictReader(f))
    with tempfile.TemporaryDirectory() as scratch:
        for round_ in range(0 if args.refit else max(args.rounds, 1)):
            one_rank = float("nan")
            if args.rounds:
                alone = run(args.build, args, args.weights[0], os.path.join(scratch, f"one{round_}.csv"), 1)
                one_rank = alone[0]["step_s"]
                rows += [dict(round=round_, **r, one_rank_step_s=one_rank) for r in alone]
            order = args.weights if round_ % 2 == 0 else args.weights[::-1]
            for i, weights in enumerate(order):
                for r in run(args.build, args, weights, os.path.join(scratch, f"run{round_}_{i}.csv")):
                    rows.append(dict(round=round_, **r, one_rank_step_s=one_rank))
    if not args.refit:
        with open(os.path.join(args.results, args.stem + ".csv"), "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            writer.writeheader()
            writer.writerows(rows)

    rows = [r for r in rows if int(r.get("ranks", 2)) == 2]  # the fit reads the 2-rank runs
    # Every cut of this tank gives a rank walls and dummies in nearly one ratio, so the fit cannot tell their costs
    # apart: it fits a fluid particle's cost and one boundary particle's, wall or dummy.
    counts = np.array([[float(r["fluid"]), float(r["wall"]) + float(r["dummy"])] for r in rows])
    costs = []
    print(f"{'phase':<11} {'fluid ns':>10} {'boundary ns':>12}  largest residual")
    for phase in PHASES + ["neighbours+predict"]:
        seconds = np.array([sum(float(r[p]) for p in phase.split("+")) for r in rows])
        c, _ = nnls(counts, seconds)
        residual = np.max(np.abs(counts @ c - seconds) / seconds)
        costs.append(dict(phase=phase, fluid=c[0] * 1e9, boundary=c[1] * 1e9, largest_residual=residual))
        print(f"{phase:<11} {c[0] * 1e9:10.1f} {c[1] * 1e9:12.1f}  {residual:.1%}")
    with open(os.path.join(args.results, args.stem + "_costs.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(costs[0].keys()))
        writer.writeheader()
        writer.writerows(costs)
    if args.rounds or args.refit:
        for weights in sorted({r["weights"] for r in rows}):
            mine = [r for r in rows if r["weights"] == weights and int(r["rank"]) == 0]
            ratios = sorted(float(r.get("one_rank_step_s", "nan")) / float(r["step_s"]) for r in mine)
            steps = sorted(float(r["step_s"]) for r in mine)
            print(f"weights {weights}: 2 ranks " + ", ".join(f"{s:.3f}" for s in steps) + " s a step, " +
                  ", ".join(f"{r:.3f}" for r in ratios) + "x the round's one-rank run")
    clean = costs[-1]
    print(f"weight of a wall or dummy particle from the neighbour phase and the predictor: "
          f"{clean['boundary'] / clean['fluid']:.3f} of a fluid particle's")

if __name__ == "__main__":
    main()
