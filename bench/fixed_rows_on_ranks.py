#!/usr/bin/python3
"""The dam break's step on 1 and 2 ranks with `auto` keeping a row for every particle (its default, refresh=galerkin)
and with the rows the unknowns (`auto:refresh=none`, what `auto` did on ranks before): issue 40, items 2 and 3
(docs/scaling.md). One thread per rank, the runs one after another; each run's summary row (bench_distributed_step's
CSV), the per-step traces with the solver added, and a chart of the step time against the step.

  /usr/bin/python3 bench/fixed_rows_on_ranks.py BUILD --dim 3 --fluid 4.3e5 --steps 20 --stem fixed_rows_ranks_3d
  (--replot draws the chart again from the CSV files without running)
"""
import argparse
import csv
import os
import subprocess
import sys

from plot_migration import plot_step_times

SOLVERS = ["auto", "auto:refresh=none"]


def run(build, ranks, solver, args, summary, trace):
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    command = ["mpirun", "--oversubscribe", "-np", str(ranks), os.path.join(build, "bench", "bench_distributed_step"),
               "--dim", str(args.dim), "--fluid", args.fluid, "--steps", str(args.steps), "--solver", solver,
               "--migrate-every", "20", "--trace", trace, "--out", summary]
    print(" ".join(command), flush=True)
    subprocess.run(command, env=env, check=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("--dim", type=int, default=2)
    parser.add_argument("--fluid", default="1e6")
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--stem", default="fixed_rows_ranks")
    parser.add_argument("--results", default="bench/results")
    parser.add_argument("--replot", action="store_true")
    args = parser.parse_args()
    summary = os.path.join(args.results, args.stem + ".csv")
    trace_file = os.path.join(args.results, args.stem + "_trace.csv")
    if args.replot:
        with open(trace_file, newline="") as f:
            traces = list(csv.DictReader(f))
    else:
        if os.path.exists(summary):
            os.remove(summary)
        traces = []
        for solver in SOLVERS:
            for ranks in (1, 2):
                trace = os.path.join(args.results, f"{args.stem}_{ranks}_{len(traces)}.tmp.csv")
                run(args.build, ranks, solver, args, summary, trace)
                with open(trace, newline="") as f:
                    traces += [dict(row, solver=solver) for row in csv.DictReader(f)]
                os.remove(trace)
        with open(trace_file, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(traces[0].keys()))
            writer.writeheader()
            writer.writerows(traces)

    with open(summary, newline="") as f:
        rows = list(csv.DictReader(f))
    step = {(int(r["ranks"]), r["solver"]): float(r["step_s"]) for r in rows}
    for solver in SOLVERS:
        if (1, solver) in step and (2, solver) in step:
            print(f"{solver}: 1 rank {step[(1, solver)]:.3f} s, 2 ranks {step[(2, solver)]:.3f} s a step, "
                  f"speed-up {step[(1, solver)] / step[(2, solver)]:.3f}")

    runs = []
    for solver in SOLVERS:
        for ranks in (1, 2):
            label = f"{solver}, {ranks} rank" + ("s" if ranks > 1 else "")
            runs.append((label, "-" if solver == "auto" else "--",
                         [r for r in traces if r["solver"] == solver and int(r["ranks"]) == ranks]))
    dim = "3-D (SPHERIC Test 2)" if args.dim == 3 else "2-D"
    plot_step_times(runs, f"{dim} dam break, about {float(args.fluid):.1e} fluid particles, one thread per rank",
                    os.path.join(args.results, args.stem + ".png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
