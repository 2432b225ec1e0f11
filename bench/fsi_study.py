#!/usr/bin/python3
"""The FSI scenes of docs/fsi.md: the dam break on the plate for the seed's three moduli and a rigid plate at the
seed's spacing, and the rubber gate at three spacings.

  bench/fsi_study.py BUILD_DIR [--results bench/results] [--runs runs/fsi-study] [--jobs 2] [--plot-only]

Writes fsi_plate.csv / .png (plate-top displacement and load against time) and fsi_gate.csv / .png (free-end
displacements, water level, the largest displacement and its time against spacing). One OpenMP thread per run.
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
import numpy as np

PLATE = [("E6e6", ["--modulus", "6e6"]), ("E1.2e7", ["--modulus", "1.2e7"]), ("E2.38e7", ["--modulus", "2.38e7"]),
         ("rigid", ["--rigid"])]
GATE = [0.000625, 0.001, 0.00125]  # the longest run first


def run(build, out, args):
    exe = Path(build) / "apps" / "fsi" / "fsi"
    cmd = [str(exe), *args, "--frames", "10", "--out", str(out)]
    subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    s = json.loads((out / "summary.json").read_text())
    s["command"] = " ".join(cmd[1:])
    return s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/fsi-study")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--plate-end", type=float, default=0.4)
    ap.add_argument("--gate-end", type=float, default=0.3)
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)
    cases = {f"gate-dx{dx}": ["--scene", "gate", "--dx", repr(dx), "--end-time", repr(a.gate_end)] for dx in GATE}
    cases.update({f"plate-{name}": ["--scene", "plate", "--dx", "0.002", "--end-time", repr(a.plate_end), *args]
                  for name, args in PLATE})
    if a.plot_only:
        summaries = {n: json.loads((runs / n / "summary.json").read_text()) for n in cases
                     if (runs / n / "summary.json").exists()}
    else:
        with ThreadPoolExecutor(max_workers=a.jobs) as pool:
            futures = {n: pool.submit(run, a.build, runs / n, args) for n, args in cases.items()}
            summaries = {n: f.result() for n, f in futures.items()}

    rows = []
    for n, s in summaries.items():
        c, t = s.get("checks", {}), s.get("timings", {})
        rows.append({"case": n, "status": s["status"], "time_s": s["time_s"], "steps": s["steps"],
                     "largest_probe_ux_m": c.get("largest_probe_ux_m"), "at_s": c.get("at_s"),
                     "pressure_work_j_per_m": c.get("pressure_work_on_body_j_per_m"),
                     "body_energy_j_per_m": c.get("body_energy_j_per_m"), "fluid_s": t.get("fluid_s"),
                     "coupling_s": t.get("coupling_s"), "solid_s": t.get("solid_s"), "wall_s": t.get("wall_s"),
                     "error": s.get("error", "")})
        print(rows[-1], flush=True)
    with open(results / "fsi_study.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for name, _ in reversed(PLATE):  # the rigid plate's raw load first, beneath the relaxed ones
        f = runs / f"plate-{name}" / "tip.csv"
        if not f.exists():
            continue
        d = np.genfromtxt(f, delimiter=",", names=True)
        if name != "rigid":
            ax.plot(d["t"], 1e3 * d["ux"], lw=1, label=f"E = {name[1:]} Pa")
        bx.plot(d["t"], d["force_x"], lw=0.5 if name == "rigid" else 0.9, alpha=0.5 if name == "rigid" else 1.0,
                color="grey" if name == "rigid" else None,
                label="rigid (raw)" if name == "rigid" else f"E = {name[1:]} Pa (relaxed 0.1)")
    ax.set_ylabel("plate top u_x [mm]")
    ax.set_title("Dam break on an elastic plate (l0 = 0.002 m, the seed's spacing)")
    ax.legend(fontsize=8)
    bx.set_ylabel("pressure load on the plate [N/m]")
    bx.set_xlabel("t [s]")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "fsi_plate.png", dpi=120)

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for dx in GATE:
        f = runs / f"gate-dx{dx}" / "tip.csv"
        if not f.exists():
            continue
        d = np.genfromtxt(f, delimiter=",", names=True)
        line, = ax.plot(d["t"], 1e3 * d["ux"], lw=1, label=f"u_x, dx = {1e3 * dx:g} mm")
        ax.plot(d["t"], 1e3 * d["uy"], lw=1, ls="--", color=line.get_color(), label=f"u_y, dx = {1e3 * dx:g} mm")
        bx.plot(d["t"], 1e3 * d["level"], lw=1, color=line.get_color(), label=f"dx = {1e3 * dx:g} mm")
    ax.set_ylabel("gate free end [mm]")
    ax.set_title("Rubber gate (Antoci et al. 2007): free-end displacement")
    ax.legend(fontsize=8)
    bx.set_ylabel("water level behind the gate [mm]")
    bx.set_xlabel("t [s]")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "fsi_gate.png", dpi=120)


if __name__ == "__main__":
    main()
