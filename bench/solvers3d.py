#!/usr/bin/python3
"""Which pressure solver the 3-D dam break (SPHERIC Test 2) should take: the run stepped with each candidate, one
OpenMP thread, one run at a time, in one script, so the ratios come from one machine state; and, if the sample PPEs
are on disk, every backend on the 3-D sample beside the 2-D one of the same size (bench_solvers --files-only).

  bench/solvers3d.py BUILD_DIR [--results bench/results] [--runs runs/solvers3d] [--dx 0.05] [--end-time 0.5]
                     [--plot-only]

Writes solvers3d.csv (one row per run: wall time, steps, the solves and their setups, the mean iterations, P1's
arrival and first peak and H2's and H4's errors, so that a solver that changes the answer shows it) and solvers3d.png
(wall time split into solve + setup and the rest, per solver; and, from solvers_samples_3d.csv, setup + solve per
backend on the 2-D and 3-D samples).
"""
import argparse
import csv
import json
import os
import subprocess
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

# The classic baseline first; then what auto chooses between (Jacobi-CG; AMG-PCG reused on the filtered PPE) and
# AMG-PCG set up every step.
SOLVERS = ["eigen-cg", "eigen-cg:precond=jacobi", "hypre-pcg:filter=0.2", "hypre-pcg:reuse=20,filter=0.2", "auto"]
SAMPLES = ["dambreak_1e5", "dambreak3d_1e5"]


def run(build, out, dx, end_time, solver):
    exe = Path(build) / "apps" / "dambreak" / "dambreak"
    cmd = [str(exe), "--dim", "3", "--dx", str(dx), "--end-time", str(end_time), "--frames", "0", "--solver", solver,
           "--out", str(out)]
    proc = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    s = json.loads((out / "summary.json").read_text())
    t, c = s.get("timings", {}), s.get("checks", {})
    iterations = []
    with open(out / "solves.csv") as f:
        for row in csv.DictReader(f):
            iterations.append(float(row["iterations"]))
    return {"status": s.get("status"), "exit": proc.returncode, "steps": s.get("steps"), "wall_s": t.get("total_s"),
            "solve_s": t.get("solve_s"), "setup_s": t.get("solver_setup_s"),
            "mean_iterations": sum(iterations) / max(1, len(iterations)),
            "p1_arrival_s": c.get("p1_arrival_s"), "p1_first_peak_pa": c.get("p1_first_peak_pa"),
            "h2_mean_abs_error": c.get("h2_mean_absolute_error_over_column_height"),
            "h4_mean_abs_error": c.get("h4_mean_absolute_error_over_column_height"), "command": " ".join(cmd[1:])}


def samples(build, results):
    """bench_solvers on the 2-D and 3-D samples of ~1e5 unknowns, if both are on disk; returns the CSV's path."""
    data = Path(__file__).resolve().parent.parent / "data" / "ppe"
    files = [data / f"{n}.mtx.gz" for n in SAMPLES]
    if not all(f.exists() for f in files):
        print(f"skipping the sample matrices: make them with `make sample-ppes SAMPLES=large` ({', '.join(SAMPLES)})")
        return None
    out = results / "solvers_samples_3d.csv"
    exe = Path(build) / "bench" / "bench_solvers"
    specs = ";".join(["eigen-cg:precond=ic", "eigen-cg:precond=jacobi", "cholmod", "hypre-amg", "hypre-pcg",
                      "hypre-pcg:filter=0.2"])
    subprocess.run([str(exe), "--files-only", "--solvers", specs, "--out", str(out), *map(str, files)],
                   env=dict(os.environ, OMP_NUM_THREADS="1"), check=True)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/solvers3d")
    ap.add_argument("--dx", type=float, default=0.05)
    ap.add_argument("--end-time", type=float, default=0.5)
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)
    if a.plot_only:
        with open(results / "solvers3d.csv") as f:
            rows = list(csv.DictReader(f))
    else:
        rows = []
        for solver in SOLVERS:
            out = runs / solver.replace(":", "_").replace(",", "_").replace("=", "")
            r = {"solver": solver, "dx_m": a.dx, "end_time_s": a.end_time,
                 **run(a.build, out, a.dx, a.end_time, solver)}
            print(r, flush=True)
            rows.append(r)
        with open(results / "solvers3d.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        samples(a.build, results)

    sample_rows = []
    if (results / "solvers_samples_3d.csv").exists():
        with open(results / "solvers_samples_3d.csv") as f:
            sample_rows = [r for r in csv.DictReader(l for l in f if not l.startswith("#")) if r["status"] == "ok"
                           and r["phase"] == "fresh"]
    fig, axes = plt.subplots(1, 2 if sample_rows else 1, figsize=(13 if sample_rows else 7, 4.2), squeeze=False)
    ax = axes[0][0]
    names = [r["solver"] for r in rows]
    solve = [float(r["solve_s"]) + float(r["setup_s"] or 0) for r in rows]
    other = [float(r["wall_s"]) - s for r, s in zip(rows, solve)]
    ax.barh(names, solve, color="#f0027f", label="pressure solve + setup")
    ax.barh(names, other, left=solve, color="#bbbbbb", label="everything else")
    base = float(rows[0]["wall_s"])
    for y, r in enumerate(rows):
        ax.text(float(r["wall_s"]), y, f" {base / float(r['wall_s']):.2f}x", va="center", fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel(f"wall time [s], dx {rows[0]['dx_m']} m to {rows[0]['end_time_s']} s (label: IC-CG / this)")
    ax.legend(fontsize=8, loc="lower right")
    if sample_rows:
        bx = axes[0][1]
        def name(r):
            return r["backend"].replace(",tol=1e-8", "").replace(":tol=1e-8", "")
        backends = list(dict.fromkeys(name(r) for r in sample_rows))
        for k, source in enumerate(dict.fromkeys(r["source"] for r in sample_rows)):
            by = {name(r): r for r in sample_rows if r["source"] == source}
            y = [i + (k - 0.5) * 0.38 for i in range(len(backends))]
            total = [float(by[b]["total_s"]) if b in by else 0.0 for b in backends]
            n = next(iter(by.values()))["n"]
            bx.barh(y, total, height=0.36, label=f"{source.replace('.mtx.gz', '')} ({int(n):,} unknowns)")
        bx.set_yticks(range(len(backends)), backends)
        bx.invert_yaxis()
        bx.set_xscale("log")
        bx.set_xlabel("setup + solve from x = 0 [s]")
        bx.legend(fontsize=8)
    fig.suptitle("The 3-D dam break's pressure solver, one thread", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / "solvers3d.png", dpi=120)


if __name__ == "__main__":
    main()
