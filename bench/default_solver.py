#!/usr/bin/python3
"""The default pressure solver against the classic path: every scene run with `--solver auto` (the default) and with
`--solver eigen-cg` (incomplete-Cholesky CG, the classic MPS baseline), alternating, one OpenMP thread, one run at a
time, so that each ratio comes from one script on one machine state.

  bench/default_solver.py BUILD_DIR [--results bench/results] [--runs runs/default-solver] [--repeats 2]
                          [--plot-only]

Writes default_solver.csv (one row per run: wall time, particle-steps per second, the solve and its setup, the
unknowns' mean iterations) and default_solver.png (the speed-up of auto over the classic path per scene, and where the
step's time goes).
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

# name -> (app, arguments): each scene at a size where the solve matters, a few tens of seconds per run.
CASES = {
    "inlet channel Re 40": ("poiseuille", "--mode inlet --re 40 --across 20 --end-time 2 --frames 0"),
    "body-force channel": ("poiseuille", "--mode body-force --across 20 --end-time 2 --frames 0"),
    "hydrostatic tank": ("hydrostatic", "--end-time 0.5 --window 0.1 --frames 0"),
    "dam break H/50": ("dambreak", "--column classic --end-time 0.5 --frames 0"),
    "Taylor-Couette": ("rotating", "--scene couette --across 16 --times 0.2 --frames 0"),
    "screw channel": ("rotating", "--scene channel --across 16 --times 0.1 --frames 0"),
    "FSI plate": ("fsi", "--scene plate --end-time 0.2 --frames 0"),
}
SOLVERS = ["eigen-cg", "auto"]


def run(build, out, app, args, solver):
    exe = Path(build) / "apps" / app / app
    cmd = [str(exe), *args.split(), "--solver", solver, "--out", str(out)]
    proc = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    s = json.loads((out / "summary.json").read_text())
    t = s.get("timings", {})
    return {"status": s.get("status"), "exit": proc.returncode, "steps": s.get("steps"), "wall_s": t.get("total_s"),
            "particle_steps_per_s": t.get("particle_steps_per_s"), "solve_s": t.get("solve_s"),
            "setup_s": t.get("solver_setup_s"), "command": " ".join(cmd[1:])}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/default-solver")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)
    if a.plot_only:
        with open(results / "default_solver.csv") as f:
            rows = list(csv.DictReader(f))
    else:
        rows = []
        for name, (app, args) in CASES.items():
            for repeat in range(a.repeats):
                for solver in SOLVERS:
                    out = runs / f"{name.replace(' ', '_').replace('/', '')}-{solver}-{repeat}"
                    r = {"case": name, "solver": solver, "repeat": repeat, **run(a.build, out, app, args, solver)}
                    print(r, flush=True)
                    rows.append(r)
        with open(results / "default_solver.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    best = {}  # (case, solver) -> the fastest repeat's row
    for r in rows:
        key = (r["case"], r["solver"])
        if key not in best or float(r["wall_s"]) < float(best[key]["wall_s"]):
            best[key] = r
    names = list(dict.fromkeys(r["case"] for r in rows))
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.2))
    ratios = [float(best[(n, "eigen-cg")]["wall_s"]) / float(best[(n, "auto")]["wall_s"]) for n in names]
    ax.barh(names, ratios, color="#386cb0")
    for y, v in enumerate(ratios):
        ax.text(v, y, f" {v:.2f}x", va="center", fontsize=8)
    ax.axvline(1.0, color="grey", lw=0.8)
    ax.set_xlabel("classic IC-CG wall time / auto wall time (fastest of the repeats)")
    ax.invert_yaxis()
    for k, solver in enumerate(SOLVERS):
        solve = [float(best[(n, solver)]["solve_s"]) + float(best[(n, solver)]["setup_s"] or 0) for n in names]
        other = [float(best[(n, solver)]["wall_s"]) - s for n, s in zip(names, solve)]
        y = [i + (k - 0.5) * 0.38 for i in range(len(names))]
        bx.barh(y, solve, height=0.36, color=["#f0027f", "#386cb0"][k], label=f"{solver}: pressure solve + setup")
        bx.barh(y, other, left=solve, height=0.36, color="#bbbbbb", label="everything else" if k else None)
    bx.set_yticks(range(len(names)), names)
    bx.invert_yaxis()
    bx.set_xlabel("wall time of the run [s]")
    bx.legend(fontsize=8)
    fig.suptitle("The default solver (auto) against the classic IC-CG path, one thread", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / "default_solver.png", dpi=120)


if __name__ == "__main__":
    main()
