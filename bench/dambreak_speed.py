#!/usr/bin/python3
"""Speed of the seed dam-break column at the seed's spacing (H/50, 5,000 fluid particles) and at 4x the particles
(H/100), each solver against the classic path (IC-CG from zero), to t sqrt(g/H) = 3 (past the first impact), with the
impact figures beside each to show the accuracy did not move. One thread; the runs one after another.

  bench/dambreak_speed.py BUILD_DIR [--results bench/results] [--sizes 50,100]
"""
import argparse
import csv
import json
import os
import subprocess
import tempfile
from pathlib import Path

SOLVERS = [("IC-CG from zero (classic)", "eigen-cg", True), ("IC-CG warm", "eigen-cg", False),
           ("Jacobi-CG warm", "eigen-cg:precond=jacobi", False), ("AMG-PCG warm", "hypre-pcg", False),
           ("CHOLMOD", "cholmod", False)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--sizes", default="50,100")
    ap.add_argument("--solvers", default=",".join(name for name, _, _ in SOLVERS),
                    help="which of the solvers to run, by name (comma-separated); the first is the ratios' base")
    args = ap.parse_args()
    exe = Path(args.build) / "apps" / "dambreak" / "dambreak"
    end_time = 3.0 / 9.81 ** 0.5
    rows = []
    for per_h in [int(n) for n in args.sizes.split(",")]:
        base = None
        for name, spec, cold in [s for s in SOLVERS if s[0] in args.solvers.split(",")]:
            with tempfile.TemporaryDirectory() as out:
                cmd = [str(exe), "--column", "seed", "--dx", repr(1.0 / per_h), "--end-time", repr(end_time),
                       "--solver", spec, "--frames", "0", "--out", out] + (["--cold-start"] if cold else [])
                subprocess.run(cmd, capture_output=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
                s = json.loads((Path(out) / "summary.json").read_text())
            t, impact = s.get("timings", {}), s.get("checks", {}).get("impact", {})
            rate = t.get("particle_steps_per_s", 0.0)
            base = base or rate
            rows.append({"H_over_dx": per_h, "fluid": s["particles"]["fluid"], "solver": name, "spec": spec,
                         "cold_start": cold, "status": s["status"], "steps": s["steps"],
                         "particle_steps_per_s": rate, "ratio_to_classic": rate / base if base else "",
                         "solve_s": t.get("solve_s"), "solver_setup_s": t.get("solver_setup_s"),
                         "total_s": t.get("total_s"), "arrival": impact.get("arrival_t_sqrt_g_over_H", ""),
                         "first_peak": impact.get("first_peak_over_rho_g_H", "")})
            print(rows[-1], flush=True)
            Path(args.results).mkdir(parents=True, exist_ok=True)
            with open(Path(args.results) / "dambreak_speed.csv", "w", newline="") as f:  # after every run
                w = csv.DictWriter(f, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)


if __name__ == "__main__":
    main()
