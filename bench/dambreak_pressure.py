#!/usr/bin/python3
"""The free-surface pressure treatments on the seed column (docs/pressure.md): for each treatment of the projection
(mps::set_pressure_treatment) and spacing, the wall pressure at 0.2 H against Buchner (arrival, first peak, noise as a
fraction of the range and as an RMS in rho g H, plateau, second impact) and at every wall probe. Writes
bench/results/dambreak_treatments.csv and a chart of the 0.2 H signal of each treatment against the experiment.

  bench/dambreak_pressure.py BUILD_DIR [--spacings 25,50] [--treatments none,hs,...] [--runs DIR] [--jobs 2]
                             [--name dambreak_treatments]
  bench/dambreak_pressure.py BUILD_DIR --spacings 25,50,100 --treatments none,hs --name dambreak_pressure_spacings

One thread per run, two runs at a time: H/25 takes about 15 s a run, H/50 about 3 min, H/100 about 25 min. A run whose
summary is already in --runs is read, not rerun (delete the folder to rerun it).
"""
import argparse
import csv
import json
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

TREATMENTS = ["none", "hs", "hl", "ecs", "hs+ecs", "hs+hl", "hs+hl+ecs", "gc", "hs+hl+ecs+gc"]
FIGURES = ["arrival", "first_peak", "noise", "noise_rms", "plateau", "second_arrival", "second_peak"]
KEYS = {"arrival": "arrival_t_sqrt_g_over_H", "first_peak": "first_peak_over_rho_g_H", "noise": "noise_over_range",
        "noise_rms": "noise_rms_over_rho_g_H", "plateau": "plateau_over_rho_g_H",
        "second_arrival": "second_arrival_t_sqrt_g_over_H", "second_peak": "second_peak_over_rho_g_H"}


def seed_bench_setup(runs, spacings, add_options=lambda parser: None):
    """The seed-column benches' command line, BUILD [--results] [--runs] [--spacings] [--jobs] and the caller's own
    options: (the arguments, the results folder (made), the runs folder, the dambreak app, the spacings' N of H/N)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default=runs)
    ap.add_argument("--spacings", default=spacings)
    ap.add_argument("--jobs", type=int, default=2)
    add_options(ap)
    args = ap.parse_args()
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    return (args, results, Path(args.runs), Path(args.build) / "apps" / "dambreak" / "dambreak",
            [int(n) for n in args.spacings.split(",")])


def write_rows(path, rows):
    """A CSV of dicts; its columns are every key in order of first appearance (a row may leave some empty)."""
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(dict.fromkeys(k for row in rows for k in row)))
        writer.writeheader()
        writer.writerows(rows)


def run(exe, out, treatment, across, extra):
    summary = out / "summary.json"
    if summary.exists():
        return json.loads(summary.read_text())
    out.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(exe), "--column", "seed", "--dx", repr(1.0 / across), "--pressure-treatment", treatment,
                    "--frames", "0", "--out", str(out), *extra], capture_output=True,
                   env=dict(os.environ, OMP_NUM_THREADS="1"))
    return json.loads(summary.read_text())


def plot_against_buchner(chart, spacings, curves, top=1.6):
    """One panel per spacing: Buchner's 0.2 H record and the 31-step mean of each run's, curves(across) giving
    (label, pressure.csv) pairs; a missing file is left out."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    data = np.loadtxt(Path(__file__).resolve().parent.parent / "data" / "dambreak" / "buchner_exp_data.txt")
    data = data[np.argsort(data[:, 0], kind="stable")]
    fig, axes = plt.subplots(len(spacings), 1, figsize=(10, 3.2 * len(spacings)), squeeze=False)
    for ax, across in zip(axes[:, 0], spacings):
        ax.plot(data[:, 0], data[:, 1], "k.", ms=3, label="Buchner (2002)")
        for label, path in curves(across):
            if not path.exists():
                continue
            with path.open() as f:
                table = list(csv.DictReader(f))
            t = np.array([float(r["t_sqrt_g_over_H"]) for r in table])
            p = np.array([float(r["p_over_rho_g_H_at_0.2H"]) for r in table])
            smooth = np.convolve(p, np.ones(31) / 31, mode="same")
            ax.plot(t, smooth, lw=1.2, label=f"{label} (31-step mean)")
        ax.set_xlim(2, 7)
        ax.set_ylim(-0.1, top)
        ax.set_ylabel("p / (rho g H) at 0.2 H")
        ax.set_title(f"seed column, H/{across}")
        ax.legend(fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("t sqrt(g/H)")
    fig.tight_layout()
    fig.savefig(chart, dpi=110)


def plot(runs, chart, spacings, treatments):
    plot_against_buchner(chart, spacings, lambda across: [
        (t, runs / f"H{across}_{t.replace('+', '_')}" / "pressure.csv") for t in treatments])


def own_options(ap):
    ap.add_argument("--treatments", default=",".join(TREATMENTS))
    ap.add_argument("--name", default="dambreak_treatments", help="the CSV's and the chart's name in --results")
    ap.add_argument("--extra", default="", help="more dambreak options for every run, e.g. '--sensor-height 0.15'")


def main():
    args, results, runs, exe, spacings = seed_bench_setup("runs/dambreak_pressure", "25,50", own_options)
    treatments = args.treatments.split(",")
    jobs = [(t, n) for n in spacings for t in treatments]
    with ThreadPoolExecutor(args.jobs) as pool:
        summaries = list(pool.map(
            lambda j: run(exe, runs / f"H{j[1]}_{j[0].replace('+', '_')}", j[0], j[1], args.extra.split()), jobs))
    rows = []
    for (treatment, across), s in zip(jobs, summaries):
        checks = s.get("checks", {})
        base = {"treatment": treatment, "spacing": f"H/{across}", "status": s["status"], "time_s": s["time_s"],
                "steps": s["steps"], "error": s.get("error", "")}
        for probe in checks.get("wall_probes", [{"probe_H": 0.2}]):
            row = dict(base, probe_H=probe["probe_H"])
            for name in FIGURES:
                row[name] = probe.get(KEYS[name], "")
            rows.append(row)
    write_rows(results / f"{args.name}.csv", rows)
    for row in rows:
        if row["probe_H"] == 0.2:
            print(" ".join(f"{row[k]:.3f}" if isinstance(row[k], float) else str(row[k])
                           for k in ["treatment", "spacing", "status", *FIGURES]))
    plot(runs, results / f"{args.name}.png", spacings, ["none", "hs"] if "hs" in treatments else treatments[:2])


if __name__ == "__main__":
    main()
