#!/usr/bin/python3
"""The elastic plate's convergence with spacing (docs/fsi.md, issue 38 item 4): the seed's three moduli at
l0 = 0.004, 0.002 and 0.001 m (the plate must be whole spacings across and high), for one setting of the fluid's
pressure and close-pair components.

  bench/fsi_convergence.py BUILD_DIR [--setting hs+ds] [--results bench/results] [--runs runs/fsi-convergence]
                           [--jobs 2] [--end-time 0.25] [--spacings 0.004 0.002 0.001] [--plot-only]

Writes fsi_convergence_<setting>.csv (one row per run: largest plate-top u_x and when, pressure work against the
plate's energy, steps, wall time) and fsi_convergence_<setting>.png (plate-top u_x against time at each spacing, one
panel per modulus). One OpenMP thread per run, the finest runs first; a run whose summary.json exists is reused, since
the app clears its directory when it starts (delete the directory to rerun it).
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

MODULI = ["6e6", "1.2e7", "2.38e7"]
# The fluid's settings compared: the classic source with collisions (the studies' default), the higher-order source
# with them, and the dam break's default since the dynamic stabilisation (hs+ds, no collisions, no asymmetry test).
SETTINGS = {
    "none": ["--pressure-treatment", "none"],
    "hs": ["--pressure-treatment", "hs"],
    "hs+ds": ["--pressure-treatment", "hs+ds", "--collision", "0", "--asymmetry", "0"],
}


def run(build, out, args):
    exe = Path(build) / "apps" / "fsi" / "fsi"
    cmd = [str(exe), *args, "--frames", "0", "--out", str(out)]
    summary = out / "summary.json"
    if not summary.exists():
        subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    return json.loads(summary.read_text())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--setting", default="hs+ds", choices=list(SETTINGS))
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/fsi-convergence")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--end-time", type=float, default=0.25, help="the largest deflection comes at 0.17-0.20 s")
    ap.add_argument("--spacings", type=float, nargs="+", default=[0.004, 0.002, 0.001])
    ap.add_argument("--moduli", nargs="+", default=MODULI)
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs) / a.setting
    results.mkdir(parents=True, exist_ok=True)
    spacings = sorted(a.spacings)  # finest (longest) first
    cases = {(E, dx): ["--scene", "plate", "--dx", repr(dx), "--modulus", E, "--end-time", repr(a.end_time),
                       *SETTINGS[a.setting]] for dx in spacings for E in a.moduli}
    summaries = {}
    if not a.plot_only:
        with ThreadPoolExecutor(max_workers=a.jobs) as pool:
            futures = {k: pool.submit(run, a.build, runs / f"E{k[0]}-dx{k[1]}", v) for k, v in cases.items()}
            summaries = {k: f.result() for k, f in futures.items()}
    for k in cases:
        f = runs / f"E{k[0]}-dx{k[1]}" / "summary.json"
        if k not in summaries and f.exists():
            summaries[k] = json.loads(f.read_text())

    rows = []
    for (E, dx), s in sorted(summaries.items(), key=lambda kv: (float(kv[0][0]), -kv[0][1])):
        c, t = s.get("checks", {}), s.get("timings", {})
        rows.append({"setting": a.setting, "modulus_pa": E, "dx_m": dx, "status": s["status"], "time_s": s["time_s"],
                     "steps": s["steps"], "largest_probe_ux_m": c.get("largest_probe_ux_m"),
                     "at_s": c.get("largest_probe_ux_at_s"),
                     "pressure_work_j_per_m": c.get("pressure_work_on_body_j_per_m"),
                     "body_energy_j_per_m": c.get("body_energy_j_per_m"), "wall_s": t.get("wall_s"),
                     "error": s.get("error", "")})
        print(rows[-1], flush=True)
    if not rows:
        return
    with open(results / f"fsi_convergence_{a.setting}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    fig, axes = plt.subplots(1, len(a.moduli), figsize=(4 * len(a.moduli), 3.6), sharex=True)
    for ax, E in zip(np.atleast_1d(axes), a.moduli):
        for dx in reversed(spacings):
            f = runs / f"E{E}-dx{dx}" / "tip.csv"
            if not f.exists():
                continue
            d = np.genfromtxt(f, delimiter=",", names=True)
            ax.plot(d["t"], 1e3 * d["ux"], lw=1, label=f"l0 = {1e3 * dx:g} mm")
        ax.set_title(f"E = {E} Pa", fontsize=10)
        ax.set_xlabel("t [s]")
        ax.legend(fontsize=8)
    np.atleast_1d(axes)[0].set_ylabel("plate top u_x [mm]")
    fig.suptitle(f"Dam break on the elastic plate, fluid setting {a.setting}: convergence with spacing", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / f"fsi_convergence_{a.setting}.png", dpi=120)


if __name__ == "__main__":
    main()
