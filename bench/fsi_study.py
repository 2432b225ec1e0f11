#!/usr/bin/python3
"""The FSI scenes of docs/fsi.md: the dam break on the plate for the seed's three moduli and a rigid plate at the
seed's spacing, with the plate's defaults (conservative gradient, load taken whole) and with the min-reference gradient
(load relaxed by 0.1), the softest plate also at twice the spacing, and the rubber gate at three spacings.

  bench/fsi_study.py BUILD_DIR [--results bench/results] [--runs runs/fsi-study] [--jobs 2] [--plot-only]
                     [--only REGEX]

Writes fsi_study.csv (one row per run), fsi_plate_rigid.csv (the stiffest plate's load against the rigid one's),
fsi_plate.png (plate-top displacement and load against time) and fsi_gate.png (free-end displacements and the water
level against time at each spacing). One OpenMP thread per run; --only reruns the cases whose name matches REGEX and
reuses the others' outputs.
"""
import argparse
import csv
import json
import os
import re
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

PLATE = [("E6e6", ["--modulus", "6e6"]), ("E1.2e7", ["--modulus", "1.2e7"]), ("E2.38e7", ["--modulus", "2.38e7"]),
         ("rigid", ["--rigid"])]
MIN_REFERENCE = ["--pressure-gradient", "min-reference", "--relaxation", "0.1"]


def smoothed(t, f, window=0.01):
    """The load averaged over a moving window of `window` seconds."""
    out = np.empty_like(f)
    for k, tk in enumerate(t):
        near = np.abs(t - tk) <= window / 2
        out[k] = f[near].mean()
    return out


def impulse(d):
    """The load integrated over the run (trapezoids)."""
    return float(np.sum(0.5 * (d["force_x"][1:] + d["force_x"][:-1]) * np.diff(d["t"])))
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
    ap.add_argument("--only", default="", help="run only the cases whose name matches this regular expression")
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)
    cases = {f"gate-dx{dx}": ["--scene", "gate", "--dx", repr(dx), "--end-time", repr(a.gate_end)] for dx in GATE}
    # The softest plate at twice the spacing (the plate must be whole spacings across and high: 4 mm, 2 mm, 1 mm, ...).
    cases.update({f"plate-E6e6-dx{dx}": ["--scene", "plate", "--dx", repr(dx), "--end-time", repr(a.plate_end)]
                  for dx in (0.004,)})
    for suffix, extra in (("", []), ("-minref", MIN_REFERENCE)):
        cases.update({f"plate-{name}{suffix}": ["--scene", "plate", "--dx", "0.002", "--end-time", repr(a.plate_end),
                                                *args, *extra] for name, args in PLATE})
    chosen = [] if a.plot_only else [n for n in cases if re.fullmatch(a.only or ".*", n)]
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futures = {n: pool.submit(run, a.build, runs / n, cases[n]) for n in chosen}
        summaries = {n: f.result() for n, f in futures.items()}
    summaries.update({n: json.loads((runs / n / "summary.json").read_text()) for n in cases
                      if n not in summaries and (runs / n / "summary.json").exists()})

    rows = []
    for n, s in summaries.items():
        c, t = s.get("checks", {}), s.get("timings", {})
        rows.append({"case": n, "status": s["status"], "time_s": s["time_s"], "steps": s["steps"],
                     "largest_probe_ux_m": c.get("largest_probe_ux_m"), "at_s": c.get("largest_probe_ux_at_s"),
                     "pressure_work_j_per_m": c.get("pressure_work_on_body_j_per_m"),
                     "body_energy_j_per_m": c.get("body_energy_j_per_m"), "fluid_s": t.get("fluid_s"),
                     "coupling_s": t.get("coupling_s"), "solid_s": t.get("solid_s"), "wall_s": t.get("wall_s"),
                     "error": s.get("error", "")})
        print(rows[-1], flush=True)
    with open(results / "fsi_study.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    # The stiffest plate's load against the rigid plate's, each smoothed over 0.01 s.
    compare = []
    for suffix in ("", "-minref"):
        files = [runs / f"plate-{n}{suffix}" / "tip.csv" for n in ("E2.38e7", "rigid")]
        if not all(f.exists() for f in files):
            continue
        (stiff, rigid) = [np.genfromtxt(f, delimiter=",", names=True) for f in files]
        t = np.linspace(0.0, min(stiff["t"][-1], rigid["t"][-1]), 2001)
        fs = np.interp(t, stiff["t"], smoothed(stiff["t"], stiff["force_x"]))
        fr = np.interp(t, rigid["t"], smoothed(rigid["t"], rigid["force_x"]))
        compare.append({"gradient": "min-reference" if suffix else "conservative",
                        "rms_difference_n_per_m": float(np.sqrt(np.mean((fs - fr) ** 2))),
                        "rigid_rms_n_per_m": float(np.sqrt(np.mean(fr ** 2))),
                        "stiff_peak_n_per_m": float(fs.max()), "rigid_peak_n_per_m": float(fr.max()),
                        "stiff_impulse_n_s_per_m": impulse(stiff), "rigid_impulse_n_s_per_m": impulse(rigid),
                        "stiff_raw_peak_n_per_m": float(stiff["force_x"].max()),
                        "rigid_raw_peak_n_per_m": float(rigid["force_x"].max())})
        print(compare[-1], flush=True)
    if compare:
        with open(results / "fsi_plate_rigid.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(compare[0]))
            w.writeheader()
            w.writerows(compare)

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    colours = {}
    for suffix, style in (("", "-"), ("-minref", ":")):
        for name, _ in reversed(PLATE):  # the rigid plate first, beneath the elastic ones
            f = runs / f"plate-{name}{suffix}" / "tip.csv"
            if not f.exists():
                continue
            d = np.genfromtxt(f, delimiter=",", names=True)
            label = "rigid" if name == "rigid" else f"E = {name[1:]} Pa"
            gradient = "min-reference, relaxed 0.1" if suffix else "conservative"
            if name != "rigid":
                line, = ax.plot(d["t"], 1e3 * d["ux"], lw=1, ls=style, color=colours.get(name),
                                label=f"{label} ({gradient})")
                colours[name] = line.get_color()
            if suffix == "":
                bx.plot(d["t"], smoothed(d["t"], d["force_x"]), lw=0.9, color=colours.get(name, "grey"),
                        label=label)
    ax.set_ylabel("plate top u_x [mm]")
    ax.set_title("Dam break on an elastic plate (l0 = 0.002 m, the seed's spacing)")
    ax.legend(fontsize=7)
    bx.set_ylabel("load on the plate, 0.01 s mean [N/m]")
    bx.set_xlabel("t [s]")
    bx.set_title("conservative gradient (the plate's default)", fontsize=9)
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
