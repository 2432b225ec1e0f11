#!/usr/bin/python3
"""Run-to-run robustness of the seed column's wall pressure (docs/dambreak.md, issue 38): the default run beside the
same run with another solver or shifting coefficient, at each spacing, against Buchner at 0.2 H. Writes
bench/results/dambreak_robustness.csv (arrival, first peak, noise, plateau, second impact at 0.2 H; the backstop's
returns) and a chart of each variant's 0.2 H signal against the experiment.

  bench/dambreak_robustness.py BUILD_DIR [--spacings 25,50,100] [--runs DIR] [--jobs 2]

One thread per run, two runs at a time: an H/50 run took about 2.5 min here and an H/100 run 20-36 min beside other
runs. A run whose summary is already in --runs is read, not rerun (delete it to rerun).
"""
import argparse
import csv
import json
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from dambreak_pressure import FIGURES, KEYS

# label, folder, the options beside --column seed --dx; the shifting variants at H/50 only
VARIANTS = [("auto (default)", "auto", []), ("IC-CG", "eigen-cg", ["--solver", "eigen-cg"]),
            ("Jacobi-CG", "eigen-cg_precond_jacobi", ["--solver", "eigen-cg:precond=jacobi"]),
            ("shifting 0.25", "v_shift025", ["--shifting", "0.25"]), ("shifting 1", "v_shift1", ["--shifting", "1"])]
SHIFTING_AT = 50


def variants_at(across):
    return [v for v in VARIANTS if across == SHIFTING_AT or not v[1].startswith("v_")]


def folder(runs, name, across):
    return runs / (f"{name}_{1.0 / across!r}" if not name.startswith("v_") else name)


def run(exe, out, options, across):
    summary = out / "summary.json"
    if not summary.exists():
        out.mkdir(parents=True, exist_ok=True)
        subprocess.run([str(exe), "--column", "seed", "--dx", repr(1.0 / across), *options, "--out", str(out)],
                       capture_output=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    return json.loads(summary.read_text())


def plot(runs, chart, spacings):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    data = np.loadtxt(Path(__file__).resolve().parent.parent / "data" / "dambreak" / "buchner_exp_data.txt")
    data = data[np.argsort(data[:, 0], kind="stable")]
    fig, axes = plt.subplots(len(spacings), 1, figsize=(10, 3.2 * len(spacings)), squeeze=False)
    for ax, across in zip(axes[:, 0], spacings):
        ax.plot(data[:, 0], data[:, 1], "k.", ms=3, label="Buchner (2002)")
        for label, name, _ in variants_at(across):
            with (folder(runs, name, across) / "pressure.csv").open() as f:
                table = list(csv.DictReader(f))
            t = np.array([float(r["t_sqrt_g_over_H"]) for r in table])
            p = np.array([float(r["p_over_rho_g_H_at_0.2H"]) for r in table])
            ax.plot(t, np.convolve(p, np.ones(31) / 31, mode="same"), lw=1.1, label=f"{label} (31-step mean)")
        ax.set_xlim(2, 7)
        ax.set_ylim(-0.1, 1.3)
        ax.set_ylabel("p / (rho g H) at 0.2 H")
        ax.set_title(f"seed column, H/{across}")
        ax.legend(fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("t sqrt(g/H)")
    fig.tight_layout()
    fig.savefig(chart, dpi=110)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/dambreak_robustness")
    ap.add_argument("--spacings", default="25,50,100")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    results, runs = Path(args.results), Path(args.runs)
    results.mkdir(parents=True, exist_ok=True)
    exe = Path(args.build) / "apps" / "dambreak" / "dambreak"
    spacings = [int(s) for s in args.spacings.split(",")]
    jobs = [(across, v) for across in spacings for v in variants_at(across)]
    with ThreadPoolExecutor(args.jobs) as pool:
        summaries = list(pool.map(lambda j: run(exe, folder(runs, j[1][1], j[0]), j[1][2], j[0]), jobs))
    rows = []
    for (across, (label, _, _)), s in zip(jobs, summaries):
        checks = s["checks"]
        row = {"variant": label, "spacing": f"H/{across}", "status": s["status"],
               "tank_length_m": s["parameters"]["tank_length_m"],
               "fluid_returned_to_a_face": checks["fluid_returned_to_a_face_count"],
               "most_fluid_inside_walls": checks["most_fluid_inside_walls_count"]}
        for name in FIGURES:
            row[name] = checks["impact"][KEYS[name]]
        rows.append(row)
        print(" ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row.values()))
    with (results / "dambreak_robustness.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(runs, results / "dambreak_robustness.png", spacings)


if __name__ == "__main__":
    main()
