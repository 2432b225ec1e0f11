#!/usr/bin/python3
"""PETSc's methods beside ours on the sample PPEs (data/ppe/): bench_solvers --files-only with the classic IC-CG
baseline, Jacobi-CG, hypre-pcg (plain and auto's filtered AMG) and the petsc backend with GAMG, hypre through PETSc,
ICC and Jacobi, from x = 0 at tol 1e-8, one OpenMP thread, one process, so the ratios come from one machine state.

  bench/petsc_samples.py BUILD_DIR [--results bench/results] [--samples NAME ...] [--plot-only]

Samples missing from data/ppe/ are skipped (make them with `make sample-ppes` and `make sample-ppes SAMPLES=large`).
Writes solvers_petsc.csv (bench_solvers' rows) and solvers_petsc.png (setup + solve per backend and sample, in
SpMV-equivalents of that sample's matrix on one thread).
"""
import argparse
import csv
import os
import subprocess
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

SAMPLES = ["channel_1e4", "screw_1e4", "dambreak_1e4", "dambreak_1e5", "dambreak3d_1e5"]
SPECS = ["eigen-cg:precond=ic", "eigen-cg:precond=jacobi", "hypre-pcg", "hypre-pcg:filter=0.2",
         "petsc", "petsc:pc_gamg_threshold=0.05", "petsc:pc_type=hypre", "petsc:pc_type=icc", "petsc:pc_type=jacobi"]
BASELINE = "eigen-cg:precond=ic,tol=1e-8"


def run(build, out, names):
    data = Path(__file__).resolve().parent.parent / "data" / "ppe"
    files = [data / f"{n}.mtx.gz" for n in names if (data / f"{n}.mtx.gz").exists()]
    missing = [n for n in names if not (data / f"{n}.mtx.gz").exists()]
    if missing:
        print(f"skipping {', '.join(missing)}: not on disk (make sample-ppes [SAMPLES=large])")
    if not files:
        raise SystemExit("no sample PPE on disk")
    exe = Path(build) / "bench" / "bench_solvers"
    subprocess.run([str(exe), "--files-only", "--solvers", ";".join(SPECS), "--out", str(out), *map(str, files)],
                   env=dict(os.environ, OMP_NUM_THREADS="1"), check=True)


def read(path):
    with open(path) as f:
        lines = [line for line in f if not line.startswith("#")]
    return [r for r in csv.DictReader(lines) if r["phase"] == "fresh" and r["status"] == "ok"]


def plot(rows, png):
    sources = list(dict.fromkeys(r["source"] for r in rows))
    backends = list(dict.fromkeys(r["backend"] for r in rows))
    fig, axes = plt.subplots(1, len(sources), figsize=(3.2 * len(sources), 5.2), sharey=True)
    axes = axes if len(sources) > 1 else [axes]
    for ax, source in zip(axes, sources):
        here = {r["backend"]: r for r in rows if r["source"] == source}
        spmv = float(next(iter(here.values()))["spmv_1thread_s"])
        labels, setup, solve = [], [], []
        for b in backends:
            if b not in here:
                continue
            labels.append(b.replace(",tol=1e-8", "").replace("tol=1e-8", "").rstrip(":"))
            setup.append(float(here[b]["setup_s"]) / spmv)
            solve.append(float(here[b]["solve_s"]) / spmv)
        y = range(len(labels))
        ax.barh(y, setup, color="#bbbbbb", label="setup")
        ax.barh(y, solve, left=setup, color="#1f77b4", label="solve")
        if BASELINE in here:
            base = here[BASELINE]
            ax.axvline((float(base["setup_s"]) + float(base["solve_s"])) / spmv, color="k", ls="--", lw=0.8,
                       label="IC-CG (classic)")
        ax.set_yticks(list(y), labels, fontsize=7)
        ax.invert_yaxis()
        ax.set_title(f"{source.replace('.mtx.gz', '')}\n{int(here[BASELINE]['n']) if BASELINE in here else ''} "
                     "unknowns", fontsize=9)
        ax.set_xlabel("setup + solve, SpMV-equivalents (1 thread)", fontsize=8)
    axes[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("The sample PPEs from x = 0 to tol 1e-8, one thread: PETSc beside the library's backends", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--samples", nargs="+", default=SAMPLES)
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    out = results / "solvers_petsc.csv"
    if not a.plot_only:
        run(a.build, out, a.samples)
    plot(read(out), results / "solvers_petsc.png")
    print(f"wrote {out} and {results / 'solvers_petsc.png'}")


if __name__ == "__main__":
    main()
