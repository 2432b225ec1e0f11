#!/usr/bin/python3
"""Elastic structures (apps/structure): accuracy at three spacings, the hourglass coefficient, and speed.

  bench/structure_study.py BUILD_DIR [--results bench/results] [--runs runs/structure-study] [--plot-only]
                                     [--skip-speed] [--jobs 2]

- plate (Gray, Monaghan & Swift): H/5, H/10, H/20, five periods, against the plane-strain FE reference of
  bench/plate_reference.py (period, amplitude), energy drift; the linear law at H/10; the hourglass coefficient
  alpha = 0, 1, 10, 30, 100 at H/10 with the CFL each is stable at;
- csm3 (Turek & Hron): H/5, H/10, H/20 to t = 4 s, tip u_y mean / amplitude / frequency against the reference over
  the same time;
- speed: plates of 10,240 and 100,000 particles, 300 steps, one and two threads, after the accuracy runs (alone).
Accuracy runs go --jobs at a time, one OpenMP thread each; their timings are not used.
"""
import argparse
import csv
import json
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
H = 0.02


def run(build, out, args, threads=1):
    exe = Path(build) / "apps" / "structure" / "structure"
    cmd = [str(exe), *args, "--frames", "0", "--out", str(out)]
    proc = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS=str(threads)), capture_output=True, text=True)
    summary = json.loads((out / "summary.json").read_text())
    summary["command"] = " ".join(cmd[1:])
    summary["returncode"] = proc.returncode
    return summary


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/structure-study")
    ap.add_argument("--plot-only", action="store_true", help="read the runs already in --runs")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--speed-only", action="store_true", help="only the speed runs (the machine otherwise idle)")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)

    cases = {}  # name -> app arguments
    for n in (20, 10, 5):
        cases[f"csm3-H{n}"] = ["--scene", "csm3", "--dx", repr(H / n)]
        cases[f"plate-H{n}"] = ["--scene", "plate", "--dx", repr(H / n)]
    cases["plate-H10-linear"] = ["--scene", "plate", "--dx", repr(H / 10), "--model", "linear"]
    for alpha in (0, 1, 10, 100):
        # alpha = 100 is not stable at the default CFL 0.3 (its estimate: 0.38 at H/5): run it at 0.25.
        cases[f"plate-H10-alpha{alpha}"] = ["--scene", "plate", "--dx", repr(H / 10), "--hourglass", str(alpha)] + \
            (["--cfl", "0.25"] if alpha == 100 else [])

    summaries = {}
    if a.speed_only:
        speed(a.build, runs, results)
        return
    if a.plot_only:
        for name in cases:
            f = runs / name / "summary.json"
            if f.exists():
                summaries[name] = json.loads(f.read_text())
    else:
        with ThreadPoolExecutor(max_workers=a.jobs) as pool:
            futures = {name: pool.submit(run, a.build, runs / name, args) for name, args in cases.items()}
            for name, fut in futures.items():
                summaries[name] = fut.result()
                print(name, summaries[name]["status"], json.dumps(summaries[name].get("checks", {}))[:300], flush=True)

    # --- plate table
    ref = json.loads((ROOT / "bench" / "results" / "plate_reference.json").read_text())
    rows = []
    for name, s in summaries.items():
        if not name.startswith("plate"):
            continue
        c, p = s.get("checks", {}), s["parameters"]
        rows.append({"case": name, "dx_m": p["dx_m"], "particles_across": round(H / p["dx_m"]), "model": p["model"],
                     "hourglass": p["hourglass"], "cfl": p["cfl"], "stable_cfl": p.get("stable_cfl"),
                     "status": s["status"], "period_s": c.get("period_s"), "period_error": c.get("period_error"),
                     "amplitude_m": c.get("amplitude_m"), "amplitude_error": c.get("amplitude_error"),
                     "energy_drift": c.get("energy_drift_fraction"), "steps": s.get("steps")})
    if rows:
        with open(results / "structure_plate.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [2.2, 1]})
    tip = np.genfromtxt(ROOT / "bench" / "results" / "plate_reference_tip.csv", delimiter=",", names=True)
    ax.plot(tip["t"], tip["uy_tip"], "k-", lw=2.2, alpha=0.35, label="plane-strain FE (Q9, 160 x 16)")
    spacing, perr, aerr = [], [], []
    for n in (5, 10, 20):
        out = runs / f"plate-H{n}"
        if not (out / "tip.csv").exists():
            continue
        d = np.genfromtxt(out / "tip.csv", delimiter=",", names=True)
        ax.plot(d["t"], d["uy"], lw=0.9, label=f"particles, H/{n}")
        c = summaries.get(f"plate-H{n}", {}).get("checks", {})
        if c.get("period_error") is not None:
            spacing.append(n)
            perr.append(100 * c["period_error"])
            aerr.append(100 * c["amplitude_error"])
    ax.set_xlabel("t [s]")
    ax.set_ylabel("tip u_y [m]")
    ax.set_title("Oscillating plate (L = 0.2 m, H = 0.02 m): tip displacement")
    ax.legend(fontsize=8, loc="lower left")
    bx.loglog(spacing, perr, "o-", label="period")
    bx.loglog(spacing, aerr, "s-", label="amplitude")
    bx.axhline(2, color="grey", ls=":", lw=0.8)
    bx.axhline(5, color="grey", ls="--", lw=0.8)
    bx.set_xticks([5, 10, 20], ["H/5", "H/10", "H/20"])
    bx.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    bx.set_yticks([1, 2, 5, 10], ["1", "2", "5", "10"])
    bx.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    bx.set_xlabel("spacing")
    bx.set_ylabel("error against FE [%]")
    bx.set_title("Convergence (dotted: 2 %, dashed: 5 %)", fontsize=9)
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "structure_plate.png", dpi=120)

    # --- hourglass coefficient
    alphas, errs, stable = [], [], []
    for alpha, name in ((0, "plate-H10-alpha0"), (1, "plate-H10-alpha1"), (10, "plate-H10-alpha10"),
                        (30, "plate-H10"), (100, "plate-H10-alpha100")):
        s = summaries.get(name)
        if s and s.get("checks", {}).get("period_error") is not None:
            alphas.append(max(alpha, 0.1))
            errs.append(100 * s["checks"]["period_error"])
            stable.append(s["parameters"]["stable_cfl"])
    if alphas:
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.loglog(alphas, errs, "o-", label="period error [%]")
        ax.set_xlabel("hourglass coefficient alpha (0 drawn at 0.1)")
        ax.set_ylabel("plate period error against FE [%], H/10")
        ax2 = ax.twinx()
        ax2.semilogx(alphas, stable, "s--", color="C1", label="stable CFL (estimate)")
        ax2.set_ylabel("stable CFL", color="C1")
        ax.set_title("Hourglass control: accuracy against time step")
        fig.tight_layout()
        fig.savefig(results / "structure_hourglass.png", dpi=120)

    # --- csm3
    ref_t = np.genfromtxt(ROOT / "data" / "structures" / "turek_hron_csm3_tip_displacement.csv", delimiter=",",
                          names=True)
    crow = []
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax.plot(ref_t["time"], 1e3 * ref_t["Uy"], "k-", lw=2.2, alpha=0.35, label="Turek & Hron (FE)")
    bx.plot(ref_t["time"], 1e3 * ref_t["Ux"], "k-", lw=2.2, alpha=0.35, label="Turek & Hron (FE)")
    for n in (5, 10, 20):
        name = f"csm3-H{n}"
        out = runs / name
        if (out / "tip.csv").exists():
            d = np.genfromtxt(out / "tip.csv", delimiter=",", names=True)
            ax.plot(d["t"], 1e3 * d["uy"], lw=0.9, label=f"particles, H/{n}")
            bx.plot(d["t"], 1e3 * d["ux"], lw=0.9, label=f"particles, H/{n}")
        s = summaries.get(name)
        if s:
            c = s.get("checks", {})
            crow.append({"case": name, "dx_m": s["parameters"]["dx_m"], "status": s["status"],
                         "uy_mean_mm": 1e3 * c["uy"]["mean_m"], "uy_mean_ref_mm": 1e3 * c["uy_reference"]["mean_m"],
                         "uy_amplitude_mm": 1e3 * c["uy"]["amplitude_m"],
                         "uy_amplitude_ref_mm": 1e3 * c["uy_reference"]["amplitude_m"],
                         "uy_frequency_hz": c["uy"]["frequency_hz"],
                         "uy_frequency_ref_hz": c["uy_reference"]["frequency_hz"],
                         "uy_mean_error": c["uy_mean_error"], "uy_amplitude_error": c["uy_amplitude_error"],
                         "uy_frequency_error": c["uy_frequency_error"], "ux_mean_error": c["ux_mean_error"],
                         "energy_drift": c["energy_drift_fraction"], "steps": s["steps"]})
    if crow:
        with open(results / "structure_csm3.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(crow[0]))
            w.writeheader()
            w.writerows(crow)
    ax.set_xlim(0, 4)
    ax.set_ylabel("tip u_y [mm]")
    bx.set_ylabel("tip u_x [mm]")
    bx.set_xlabel("t [s]")
    ax.set_title("CSM3: the flag under gravity, tip A")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(results / "structure_csm3.png", dpi=120)

    if not (a.skip_speed or a.plot_only):
        speed(a.build, runs, results)


def speed(build, runs, results):
    """Plates of 10,240 and 100,000 particles, 300 steps, one and two threads, one run at a time."""
    srows = []
    for dx, label in ((H / 32, "10,240"), (H / 100, "100,000")):
        for threads in (1, 2):
            name = f"speed-dx{dx:.6f}-t{threads}"
            # 300 steps: dt = 0.3 dx / c_p (c_p = 64.86 m/s for the plate)
            end = 300 * 0.3 * dx / 64.858
            s = run(build, runs / name, ["--scene", "plate", "--dx", repr(dx), "--end-time", repr(end)], threads)
            t = s["timings"]
            srows.append({"particles": s["particles"]["moving"] + s["particles"]["clamped"], "threads": threads,
                          "steps": s["steps"], "steps_per_s": t["steps_per_s"],
                          "particle_steps_per_s": t["particle_steps_per_s"],
                          "spmv_equivalents_per_step": t["per_step_spmv_equivalents"],
                          "gradient_nonzeros": t["gradient_nonzeros"]})
            print(srows[-1], flush=True)
    with open(results / "structure_speed.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(srows[0]))
        w.writeheader()
        w.writerows(srows)


if __name__ == "__main__":
    main()
