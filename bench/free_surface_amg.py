#!/usr/bin/python3
"""AMG across a moving free surface (issue 40, item 2; docs/solvers.md): the seed column at H/N with `auto` (which
keeps a row for every particle once Jacobi is slow and refreshes its hierarchy's coarse operators), with Jacobi-CG
(`eigen-cg:precond=jacobi`), and, given --old, with an older build's `auto` (which rebuilt its hierarchy whenever the
unknowns changed). Per run: the PPE's setup and solve per step, iterations, how many solves kept a hierarchy, the
whole step, and the wall pressure's figures at 0.2 H (so that a speed-up that moved the flow shows). Writes
bench/results/free_surface_amg.csv and .png (the PPE's cost per step through the run).

  bench/free_surface_amg.py BUILD_DIR [--old OLD_BUILD_DIR] [--old-spacings 50] [--spacings 50,100] [--runs DIR]

One thread, one run at a time (the runs are timed): H/50 about 2 minutes a run, H/100 about 15-20. A run whose summary
is already in --runs is read, not rerun (delete the folder to rerun it).
"""
import argparse
import csv
import json
import os
import subprocess
from pathlib import Path

from dambreak_pressure import write_rows

IMPACT = {"arrival": "arrival_t_sqrt_g_over_H", "first_peak": "first_peak_over_rho_g_H",
          "second_arrival": "second_arrival_t_sqrt_g_over_H", "second_peak": "second_peak_over_rho_g_H",
          "noise_rms": "noise_rms_over_rho_g_H"}


def run(exe, out, across, solver):
    if not (out / "summary.json").exists():
        out.mkdir(parents=True, exist_ok=True)
        command = [str(exe), "--column", "seed", "--dx", repr(1.0 / across), "--frames", "0", "--out", str(out)]
        subprocess.run(command + (["--solver", solver] if solver else []), capture_output=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    summary = json.loads((out / "summary.json").read_text())
    with (out / "solves.csv").open() as f:
        solves = list(csv.DictReader(f))
    return summary, solves


def row(label, across, summary, solves):
    steps = len(solves)
    timings = summary["timings"]
    impact = summary["checks"]["impact"]
    ppe = timings["solver_setup_s"] + timings["solve_s"]
    r = {"run": label, "spacing": f"H/{across}", "steps": steps,
         "ppe_ms_per_step": 1e3 * ppe / steps,
         "setup_ms_per_step": 1e3 * timings["solver_setup_s"] / steps,
         "solve_ms_per_step": 1e3 * timings["solve_s"] / steps,
         "iterations_per_solve": sum(int(s["iterations"]) for s in solves) / steps,
         "hierarchy_kept": sum(s["setup_reused"] == "1" for s in solves),
         "amg_solves": sum(s["backend"].startswith("hypre") for s in solves),
         "step_ms": 1e3 * timings["total_s"] / steps,
         "run_s": timings["total_s"]}
    r.update({k: impact.get(v) for k, v in IMPACT.items()})
    return r


def plot(chart, curves):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    spacings = sorted({across for across, _ in curves})
    fig, axes = plt.subplots(1, len(spacings), figsize=(6 * len(spacings), 4), squeeze=False)
    for ax, across in zip(axes[0], spacings):
        for (n, label), (t, cost) in curves.items():
            if n != across:
                continue
            window = 25  # steps: a moving mean, the per-step cost jumps at each full setup
            smooth = [sum(cost[max(0, i - window):i + 1]) / (i + 1 - max(0, i - window)) for i in range(len(cost))]
            ax.plot(t, smooth, lw=1.2, label=label)
        ax.set_title(f"seed column, H/{across}")
        ax.set_xlabel("t sqrt(g/H)")
        ax.set_ylabel("PPE setup + solve per step [ms], mean over 25 steps")
        ax.set_ylim(bottom=0)
        ax.legend()
    fig.tight_layout()
    fig.savefig(chart, dpi=120)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--old", help="an older build's directory: its auto beside this one's")
    ap.add_argument("--old-spacings", help="the spacings the older build runs at (default: all)")
    ap.add_argument("--spacings", default="50")
    ap.add_argument("--runs", default="runs/free_surface_amg")
    ap.add_argument("--results", default="bench/results")
    args = ap.parse_args()
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    app = Path("apps") / "dambreak" / "dambreak"
    cases = [("auto", Path(args.build) / app, ""), ("Jacobi-CG", Path(args.build) / app, "eigen-cg:precond=jacobi")]
    old_spacings = [int(n) for n in (args.old_spacings or args.spacings).split(",")] if args.old else []
    rows, curves = [], {}
    for across in [int(n) for n in args.spacings.split(",")]:
        with_old = [("auto, old build", Path(args.old) / app, "")] if across in old_spacings else []
        for label, exe, solver in cases + with_old:
            out = Path(args.runs) / f"{label.replace(', ', '_').replace(' ', '_')}_h{across}"
            summary, solves = run(exe, out, across, solver)
            rows.append(row(label, across, summary, solves))
            params = summary["parameters"]
            scale = (params["g_m_per_s2"] / params["column_height_m"]) ** 0.5  # t -> t sqrt(g/H)
            curves[(across, label)] = ([float(s["time_s"]) * scale for s in solves],
                                       [1e3 * (float(s["setup_s"]) + float(s["solve_s"])) for s in solves])
            print(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in rows[-1].items()))
    write_rows(results / "free_surface_amg.csv", rows)
    plot(results / "free_surface_amg.png", curves)


if __name__ == "__main__":
    main()
