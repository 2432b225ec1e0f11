#!/usr/bin/python3
"""hypre-pcg's AMG preconditioner built on the filtered PPE (`filter=F`: couplings below F x the strongest lumped onto
the diagonal) against the unfiltered one: bench_solvers' tank PPEs at the library's Laplacian radius (4.1 l0) and at
3.1 l0, fresh setup and reused hierarchy, one thread.

  bench/solver_filter.py BUILD_DIR [--results bench/results] [--sizes 1e4,1e5,1e6] [--filters 0.1,0.2,0.3] [--plot-only]

Writes solver_filter.csv (bench_solvers' rows with the radius) and solver_filter.png (SpMV-equivalents per solve and
iterations against N for each filter; amortised over reuse=10: one fresh setup and nine reused ones per ten solves).
"""
import argparse
import csv
import os
import subprocess
import tempfile
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def run(build, radius, sizes, filters):
    specs = ["hypre-pcg:reuse=10"] + [f"hypre-pcg:reuse=10,filter={f}" for f in filters]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "solvers.csv"
        subprocess.run([str(Path(build) / "bench" / "bench_solvers"), "--sizes", sizes, "--radius", str(radius),
                        "--solvers", ";".join(specs), "--out", str(out)],
                       env=dict(os.environ, OMP_NUM_THREADS="1"), check=True, capture_output=True)
        with open(out) as f:
            rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    for r in rows:
        r["radius_l0"] = radius
        spec = r["backend"]
        r["filter"] = spec.split("filter=")[1].split(",")[0] if "filter=" in spec else "0"
    return rows


def amortised(rows, reuse=10):
    """Setup + solve per solve over `reuse` solves: one fresh, reuse - 1 reused, in SpMV-equivalents (1 thread)."""
    out = {}
    for r in rows:
        key = (float(r["radius_l0"]), r["filter"], int(r["n"]))
        out.setdefault(key, {})[r["phase"]] = r
    table = []
    for (radius, filt, n), ph in sorted(out.items()):
        if "fresh" not in ph or "reused" not in ph:
            continue
        fresh, reused = ph["fresh"], ph["reused"]
        spmv = float(fresh["spmv_1thread_s"])
        per_solve = (float(fresh["setup_s"]) + float(fresh["solve_s"])
                     + (reuse - 1) * (float(reused["setup_s"]) + float(reused["solve_s"]))) / reuse
        table.append({"radius_l0": radius, "filter": filt, "n": n, "amortised_spmv_equivalents": per_solve / spmv,
                      "reused_solve_spmv_equivalents": float(reused["solve_s"]) / spmv,
                      "iterations": int(reused["iterations"]), "fresh_setup_s": float(fresh["setup_s"])})
    return table


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--sizes", default="1e4,1e5,1e6")
    ap.add_argument("--filters", default="0.1,0.2,0.3")
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    path = results / "solver_filter.csv"
    if a.plot_only:
        with open(path) as f:
            rows = list(csv.DictReader(f))
    else:
        filters = a.filters.split(",")
        rows = run(a.build, 4.1, a.sizes, filters) + run(a.build, 3.1, a.sizes, filters)
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    table = amortised(rows)
    for t in table:
        print(f"r = {t['radius_l0']} l0  filter {t['filter']:>4}  n {t['n']:>8}  iterations {t['iterations']:>3}  "
              f"reused solve {t['reused_solve_spmv_equivalents']:6.1f}  amortised {t['amortised_spmv_equivalents']:6.1f} "
              f"SpMV-eq  fresh setup {t['fresh_setup_s']:.3f} s")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for radius, style in ((4.1, "-"), (3.1, "--")):
        for filt in sorted({t["filter"] for t in table}, key=float):
            sel = [t for t in table if t["radius_l0"] == radius and t["filter"] == filt]
            if not sel:
                continue
            label = f"r = {radius} l0, " + ("unfiltered" if float(filt) == 0 else f"filter {filt}")
            n = [t["n"] for t in sel]
            axes[0].plot(n, [t["amortised_spmv_equivalents"] for t in sel], "o" + style, label=label)
            axes[1].plot(n, [t["iterations"] for t in sel], "o" + style, label=label)
    axes[0].axhline(40, color="grey", ls=":", lw=1)
    axes[0].text(1e4, 40, " 40: issue 25's goal", fontsize=7, va="bottom")
    axes[0].set_ylabel("setup + solve per solve, SpMV-equivalents\n(reuse=10: 1 fresh + 9 reused setups)")
    axes[1].set_ylabel("PCG iterations (reused hierarchy)")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel("unknowns")
        ax.legend(fontsize=7)
    fig.suptitle("hypre-pcg with the AMG preconditioner built on the filtered PPE (tank, tol 1e-8, x0 = 0, 1 thread)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(results / "solver_filter.png", dpi=120)


if __name__ == "__main__":
    main()
