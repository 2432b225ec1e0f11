#!/usr/bin/python3
"""The 3-D dam break's step (SPHERIC Test 2) on 1 and 2 MPI ranks: each spacing run from rest for a few steps,
serially and under mpirun, one OpenMP thread a rank, one run at a time; wall time, particle-steps per second (rank 0's
summary) and the largest resident memory of one process (GNU time's), per particle.

  bench/scaling3d.py BUILD_DIR [--spacings 0.03,0.0116] [--end-times 0.05,0.01] [--results bench/results]
                     [--runs runs/scaling3d] [--mpiexec mpiexec] [--ranks 1,2]

Writes scaling3d.csv, one row per run. The first step (neighbour grid, AMG or IC set-up, the halo) is in the time.
"""
import argparse
import csv
import json
import os
import re
import subprocess
from pathlib import Path


def run(command, out):
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    proc = subprocess.run(["/usr/bin/time", "-v", *command, "--out", str(out)], env=env, capture_output=True,
                          text=True)
    peak_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1))
    summary = json.loads((out / "summary.json").read_text())
    return proc.returncode, peak_kb, summary


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--spacings", default="0.03,0.0116")
    ap.add_argument("--end-times", default="0.05,0.01")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/scaling3d")
    ap.add_argument("--mpiexec", default="mpiexec")
    ap.add_argument("--ranks", default="1,2", help="the rank counts to run, e.g. 2 to repeat only the MPI runs")
    a = ap.parse_args()
    exe = str(Path(a.build) / "apps" / "dambreak" / "dambreak")
    rows = []
    for dx, end in zip(map(float, a.spacings.split(",")), map(float, a.end_times.split(","))):
        for ranks in map(int, a.ranks.split(",")):
            options = [exe, "--dim", "3", "--dx", str(dx), "--end-time", str(end), "--frames", "0"]
            command = options if ranks == 1 else [a.mpiexec, "--oversubscribe", "-np", str(ranks), *options]
            out = Path(a.runs) / f"dx{dx}_ranks{ranks}"
            status, peak_kb, s = run(command, out)
            particles = s["particles"]["total"]
            t = s["timings"]
            row = {"dx_m": dx, "ranks": ranks, "particles": particles, "fluid": s["particles"]["fluid"],
                   "steps": s["steps"], "exit": status, "wall_s": t["total_s"],
                   "particle_steps_per_s": t["particle_steps_per_s"], "solve_s": t.get("solve_s"),
                   "peak_rss_mb_one_process": peak_kb / 1024,
                   "peak_bytes_per_particle": peak_kb * 1024 / particles * ranks,
                   "command": " ".join(command)}
            print(row, flush=True)
            rows.append(row)
    Path(a.results).mkdir(parents=True, exist_ok=True)
    with open(Path(a.results) / "scaling3d.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
