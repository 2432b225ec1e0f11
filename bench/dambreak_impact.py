#!/usr/bin/python3
"""Why the seed column's first peak at 0.2 H is low (docs/dambreak.md, issue 38): the front's arrival at the downstream
wall, every wall probe's arrival, and how fast the water climbs the wall past the 0.2 H sensor, at each spacing.
Writes bench/results/dambreak_impact.csv, the tongue's depth just before the impact against Ritter's shallow-water
solution (dambreak_impact_depth.csv), the noise after it (dambreak_impact_noise.csv), and a chart.

  bench/dambreak_impact.py BUILD_DIR [--spacings 25,50,100] [--runs DIR] [--jobs 2]

Each run is the default seed column to t sqrt(g/H) = 5 with a frame every 0.02 (H/100: about 16 minutes on one
thread). A run whose summary is already in --runs is read, not rerun (delete it to rerun).

The noise over the plateau (dambreak_impact_noise.csv): each probe's signal less its centred mean over 0.1, over
t sqrt(g/H) in [3.5, 5]: its RMS, its correlation with the 0.2 H probe's, the 0.2 H noise's correlation with itself one
step later, and with the step's change in the PPE's unknown count (solves.csv), which the surface test's flips move.
"""
import csv
import json
import math
import os
import re
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

from dambreak_pressure import seed_bench_setup, write_rows

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

G, H = 9.81, 1.0  # the seed column is 1 m high
END_T, FRAME_T, CHART_T = 5.0, 0.02, 3.6
PLATEAU = (3.5, 5.0)  # the checks' plateau window, where the noise is read [t sqrt(g/H)]
ARRIVAL = 0.25  # the checks' arrival level [rho g H]
SENSOR = (0.125, 0.275)  # the 0.2 H sensor's extent [H]
WETTED_LEVELS = (0.05, 0.125, 0.2, 0.275)
PROFILE_T = 2.44  # just before the front reaches the wall at H/100
PROFILE_X = np.arange(2.0, 5.3, 0.2) * H
BUCHNER = Path(__file__).resolve().parent.parent / "data" / "dambreak" / "buchner_exp_data.txt"


def run(exe, out, across):
    """The run's summary; a kept run is rerun unless it completed to END_T (an older, shorter run would leave the
    plateau window empty)."""
    summary = out / "summary.json"
    end = END_T / math.sqrt(G / H)
    if summary.exists():
        kept = json.loads(summary.read_text())
        if kept["status"] == "completed" and kept["parameters"]["end_time_s"] >= end * (1 - 1e-9):
            return kept
    out.mkdir(parents=True, exist_ok=True)
    done = subprocess.run([str(exe), "--column", "seed", "--dx", repr(1.0 / across), "--end-time", repr(end),
                           "--frames", str(round(END_T / FRAME_T)), "--out", str(out)],
                          capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    if done.returncode != 0:
        raise SystemExit(f"the H/{across} run failed ({done.returncode}):\n{done.stderr}")
    return json.loads(summary.read_text())


def fluid_frames(out, after, scale=math.sqrt(G / H)):
    """(T, fluid positions) of each frame from T = after on, T being t times `scale` (t sqrt(g/H) by default)."""
    pvd = (out / "dambreak.pvd").read_text()
    for time, name in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd):
        T = float(time) * scale
        if T < after:
            continue
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(out / name))
        reader.Update()
        frame = reader.GetOutput()
        kind = vtk_to_numpy(frame.GetPointData().GetArray("kind"))
        yield T, vtk_to_numpy(frame.GetPoints().GetData())[kind == 0]


def depth_profile(out, l0, T_at):
    """The tongue's depth over x (fluid area per unit length in bins 0.2 H wide) in the frame nearest T_at."""
    T, x = min(fluid_frames(out, T_at - FRAME_T), key=lambda frame: abs(frame[0] - T_at))
    return T, np.array([np.count_nonzero(np.abs(x[:, 0] - c) < 0.1 * H) * l0 * l0 / (0.2 * H) for c in PROFILE_X])


def ritter_depth(x, T):
    """Ritter's shallow-water dam break from the column's face at 2 H (an endless reservoir), depth over H."""
    xi = (x - 2 * H) / (T * H)
    return np.where(xi < -1, 1.0, np.clip(2 - xi, 0, None) ** 2 / 9)


def wetted_heights(out, l0, wall, after=2.2):
    """(T, height) of the water standing on the wall: the fluid within 2 l0 of the wall line, taken from the floor up
    while each particle is at most 2 l0 above the one below, the first within 1.5 l0 of the floor; the top + l0/2."""
    series = []
    for T, x in fluid_frames(out, after):
        y = np.sort(x[x[:, 0] > wall - 2 * l0, 1])
        top = 0.0
        if len(y) and y[0] < 1.5 * l0:
            gaps = np.nonzero(np.diff(y) > 2 * l0)[0]
            top = (y[gaps[0]] if len(gaps) else y[-1]) + 0.5 * l0
        series.append((T, top / H))
    return np.array(series)


def read_columns(path):
    with path.open() as f:
        table = list(csv.DictReader(f))
    return {name: np.array([float(r[name]) for r in table]) for name in table[0]}


def centred_mean(t, values, width):
    """The checks' smoothing: the mean over a centred window `width` wide in t sqrt(g/H)."""
    sums = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.searchsorted(t, t - width / 2, side="left")
    hi = np.searchsorted(t, t + width / 2, side="right")
    return (sums[hi] - sums[lo]) / (hi - lo)


def plateau_noise(out, t, probes):
    """Rows of the noise figures over PLATEAU, one per probe (see the module's doc); the RMS is the standard
    deviation over that window, where the checks' noise_rms runs from the arrival to the end."""
    noise = {name: p - centred_mean(t, p, 0.1) for name, p in probes.items()}
    window = (t >= PLATEAU[0]) & (t <= PLATEAU[1])
    reference = noise["p_over_rho_g_H_at_0.2H"][window]
    with (out / "solves.csv").open() as f:
        unknowns = {int(r["step"]): float(r["unknowns"]) for r in csv.DictReader(f)}
    # pressure.csv's row k follows step k (row 0: the start)
    steps = np.nonzero(window)[0]
    flips = np.array([unknowns[k] - unknowns.get(k - 1, unknowns[k]) for k in steps])
    rows = []
    for name, values in noise.items():
        rows.append({"probe": name.split("_at_")[1], "noise_rms": f"{values[window].std():.4f}",
                     "correlation_with_0.2H": f"{np.corrcoef(values[window], reference)[0, 1]:.3f}"})
    at_02 = next(row for row in rows if row["probe"] == "0.2H")
    at_02["lag1_autocorrelation"] = f"{np.corrcoef(reference[:-1], reference[1:])[0, 1]:.3f}"
    at_02["correlation_with_unknown_count_change"] = f"{np.corrcoef(reference, flips)[0, 1]:.3f}"
    return rows


def first_time(t, values, level):
    reached = np.nonzero(values >= level)[0]
    return float(t[reached[0]]) if len(reached) else float("nan")


def main():
    args, results, runs, exe, spacings = seed_bench_setup("runs/dambreak_impact", "25,50,100")
    with ThreadPoolExecutor(args.jobs) as pool:
        summaries = list(pool.map(lambda n: run(exe, runs / f"H{n}", n), spacings))

    rows, curves, noise_rows = [], {}, []
    for across, summary in zip(spacings, summaries):
        out, l0 = runs / f"H{across}", 1.0 / across
        wall = summary["parameters"]["tank_length_m"]
        front = read_columns(out / "front.csv")
        probes = read_columns(out / "pressure.csv")
        t = probes.pop("t_sqrt_g_over_H")
        wetted = wetted_heights(out, l0, wall)
        # front.csv's x is over the column's width, 2 H; its T is t sqrt(g/H) for the seed column
        row = {"spacing": f"H/{across}",
               "front_at_wall": first_time(front["T"], front["x_over_a"] * 2 * H, wall - l0)}
        for name, p in probes.items():
            height = name.split("_at_")[1].rstrip("H")
            row[f"arrival_{height}H"] = first_time(t, p, ARRIVAL)
        for level in WETTED_LEVELS:
            row[f"wetted_to_{level}H"] = first_time(wetted[:, 0], wetted[:, 1], level)
        rows.append(row)
        curves[across] = (t, probes, wetted, depth_profile(out, l0, PROFILE_T))
        for figures in plateau_noise(out, t, probes):
            noise_rows.append({"spacing": f"H/{across}", **figures})
        print(" ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
    write_rows(results / "dambreak_impact.csv", rows)
    write_rows(results / "dambreak_impact_noise.csv", noise_rows)
    with (results / "dambreak_impact_depth.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["x_over_H", "ritter_depth_over_H"] + [f"depth_over_H_H{n}_T{curves[n][3][0]:.3f}"
                                                                for n in spacings])
        for k, x in enumerate(PROFILE_X):
            writer.writerow([f"{x:.1f}", f"{ritter_depth(x, PROFILE_T):.4f}"] +
                            [f"{curves[n][3][1][k]:.4f}" for n in spacings])

    buchner = np.loadtxt(BUCHNER)
    buchner = buchner[np.argsort(buchner[:, 0], kind="stable")]
    buchner_arrival = first_time(buchner[:, 0], buchner[:, 1], ARRIVAL)
    fig, (probe_axes, wetted_axes, tongue_axes) = plt.subplots(1, 3, figsize=(17, 4.5))
    finest = spacings[-1]
    t, probes = curves[finest][:2]
    for name, colour in zip(probes, plt.cm.viridis(np.linspace(0, 0.9, len(probes)))):
        probe_axes.plot(t, centred_mean(t, probes[name], 0.1), lw=1.2, color=colour,
                  label=f"{name.split('_at_')[1]} (H/{finest}, mean over 0.1)")
    probe_axes.plot(buchner[:, 0], buchner[:, 1], "k.", ms=4, label="Buchner (2002), 0.2H")
    probe_axes.axhline(ARRIVAL, color="grey", lw=0.5, ls=":")
    probe_axes.set(xlim=(2.3, CHART_T), ylim=(-0.1, 1.8), xlabel="t sqrt(g/H)", ylabel="p / (rho g H)",
             title="wall probes at the first impact")
    probe_axes.legend(fontsize=8)
    for across in spacings:
        wetted = curves[across][2]
        wetted_axes.plot(wetted[:, 0], wetted[:, 1], lw=1.2, label=f"H/{across}")
    wetted_axes.axhspan(*SENSOR, color="orange", alpha=0.2, label="the 0.2H sensor")
    wetted_axes.axvline(buchner_arrival, color="k", lw=0.8, ls="--", label="Buchner's arrival at 0.2H")
    wetted_axes.set(xlim=(2.3, CHART_T), ylim=(0, 1.2), xlabel="t sqrt(g/H)", ylabel="height / H",
              title="water standing on the downstream wall")
    wetted_axes.legend(fontsize=8)
    fine_x = np.linspace(2.0, 5.36, 200) * H
    tongue_axes.plot(fine_x, ritter_depth(fine_x, PROFILE_T), "k--", lw=1, label="Ritter (shallow water)")
    for across in spacings:
        T, depth = curves[across][3]
        tongue_axes.plot(PROFILE_X, depth, "o-", ms=3, lw=1, label=f"H/{across} (t sqrt(g/H) = {T:.2f})")
    tongue_axes.set(xlim=(2, 5.4), ylim=(0, 0.5), xlabel="x / H", ylabel="depth / H",
               title=f"the tongue before the impact, t sqrt(g/H) = {PROFILE_T}")
    tongue_axes.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "dambreak_impact.png", dpi=120)


if __name__ == "__main__":
    main()
