#!/usr/bin/python3
"""The dam break at three spacings per column: errors against the experiments, a CSV and the plots of docs/dambreak.md.

  bench/dambreak_study.py BUILD_DIR [--results bench/results] [--runs runs/dambreak-study] [--quick]

classic column at a/20, a/40, a/80 (front against Martin & Moyce and Koshizuka & Oka, T <= 2.5);
seed column at H/25, H/50 (the seed's 0.02 m) and H/100 (impact at 0.2 H against Buchner, level at 1.653 H).
--quick runs the two coarser spacings only. One OpenMP thread per run.
"""
import argparse
import csv
import json
import os
import subprocess
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

DATA = Path(__file__).resolve().parent.parent / "data" / "dambreak"
CASES = [("classic", 0.146 / 20), ("classic", 0.146 / 40), ("classic", 0.146 / 80),
         ("seed", 1 / 25), ("seed", 1 / 50), ("seed", 1 / 100)]


def run(build, runs, column, dx):
    out = runs / f"{column}-dx{dx:.5f}"
    exe = Path(build) / "apps" / "dambreak" / "dambreak"
    proc = subprocess.run([str(exe), "--column", column, "--dx", repr(dx), "--frames", "10", "--out", str(out)],
                          env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    summary = json.loads((out / "summary.json").read_text())
    return out, summary, proc.returncode


def smoothed(t, p, width):
    """Centred moving average over `width` (the impact read-out's smoothing)."""
    out = np.empty_like(p)
    lo = hi = 0
    total = 0.0
    for k in range(len(p)):
        while hi < len(p) and t[hi] <= t[k] + width / 2:
            total += p[hi]
            hi += 1
        while t[lo] < t[k] - width / 2:
            total -= p[lo]
            lo += 1
        out[k] = total / (hi - lo)
    return out


def front_error(front, ref, offset=0.0):
    """Largest |x - x_exp| / x_exp over the experiment's points with 0 < T <= 2.5, the run delayed by `offset` in T."""
    ref = ref[(ref[:, 0] > 0) & (ref[:, 0] <= 2.5)]
    x = np.interp(ref[:, 0] - offset, front[:, 0], front[:, 1], left=1.0)
    return np.max(np.abs(x - ref[:, 1]) / ref[:, 1])


def best_time_offset(front, ref):
    """The delay in T (0 to 0.6, steps of 0.01) that brings the run nearest the experiment, and that error:
    what a late time origin of the experiment (the gate's release) would explain."""
    return min(((o, front_error(front, ref, o)) for o in np.arange(0.0, 0.6, 0.01)), key=lambda oe: oe[1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/dambreak-study")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--plot-only", action="store_true", help="draw the plots from the runs already in --runs")
    args = ap.parse_args()
    results, runs = Path(args.results), Path(args.runs)
    results.mkdir(parents=True, exist_ok=True)
    cases = [c for c in CASES if not args.quick or c[1] not in (0.146 / 80, 1 / 100)]
    rows, outs = [], {}
    if args.plot_only:
        outs = {(c, dx): runs / f"{c}-dx{dx:.5f}" for c, dx in cases}
        cases = []
    for column, dx in cases:
        out, s, rc = run(args.build, runs, column, dx)
        outs[(column, dx)] = out
        c, t = s.get("checks", {}), s.get("timings", {})
        impact = c.get("impact", {})
        rows.append({"column": column, "dx_m": dx, "fluid": s.get("particles", {}).get("fluid"),
                     "status": s["status"], "steps": s["steps"], "time_s": s["time_s"],
                     "front_err_mm1": c.get("martin_moyce_1_front_max_error", ""),
                     "front_err_mm2": c.get("martin_moyce_2_front_max_error", ""),
                     "front_err_ko": c.get("koshizuka_oka_front_max_error", ""),
                     "arrival": impact.get("arrival_t_sqrt_g_over_H", ""),
                     "arrival_buchner": impact.get("arrival_buchner_t_sqrt_g_over_H", ""),
                     "first_peak": impact.get("first_peak_over_rho_g_H", ""),
                     "first_peak_buchner": impact.get("first_peak_buchner_over_rho_g_H", ""),
                     "noise": impact.get("noise_over_range", ""), "spray_removed": c.get("fluid_removed_as_spray_count", ""),
                     "most_inside_walls": c.get("most_fluid_inside_walls_count", ""),
                     "deepest_past_wall_line_l0": c.get("deepest_past_wall_line_l0", ""),
                     "particle_steps_per_s": t.get("particle_steps_per_s", "")})
        print(rows[-1], flush=True)
    if rows:
        with open(results / "dambreak_study.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    fig, ax = plt.subplots(figsize=(6, 4.5))
    series = (("mm_data_1", "o", "Martin & Moyce, a = 1.125 in"), ("mm_data_2", "s", "Martin & Moyce, a = 2.25 in"),
              ("ko_data", "^", "Koshizuka & Oka"))
    refs = {name: np.loadtxt(DATA / f"{name}.txt") for name, _, _ in series}
    for name, marker, label in series:
        ax.plot(refs[name][:, 0], refs[name][:, 1], marker, mfc="none", color="k", label=label)
    offsets = []
    for (column, dx), out in outs.items():
        if column == "classic":
            f = np.loadtxt(out / "front.csv", delimiter=",", skiprows=1)
            ax.plot(f[:, 0], f[:, 1], label=f"MPS, a/{round(0.146 / dx)}")
            for name in refs:
                o, e = best_time_offset(f, refs[name])
                offsets.append({"spacing": f"a/{round(0.146 / dx)}", "series": name,
                                "error": round(front_error(f, refs[name]), 4),
                                "best_offset_T": round(o, 2), "error_at_best_offset": round(e, 4)})
                print(offsets[-1])
    if offsets:
        with open(results / "dambreak_front_offset.csv", "w", newline="") as fo:
            w = csv.DictWriter(fo, fieldnames=list(offsets[0]))
            w.writeheader()
            w.writerows(offsets)
        finest = max((k for k in outs if k[0] == "classic"), key=lambda k: 1 / k[1])
        f = np.loadtxt(outs[finest] / "front.csv", delimiter=",", skiprows=1)
        o = best_time_offset(f, refs["mm_data_2"])[0]
        ax.plot(f[:, 0] + o, f[:, 1], "k--", lw=0.8, label=f"MPS, a/{round(0.146 / finest[1])}, delayed by T = {o:.2f}")
    ax.set_xlim(0, 3)
    ax.set_ylim(1, 4)
    ax.set_xlabel("T = t sqrt(2g/a)")
    ax.set_ylabel("front x/a")
    ax.legend(fontsize=8)
    ax.set_title("Classic column: surge front")
    fig.tight_layout()
    fig.savefig(results / "dambreak_front.png", dpi=120)

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(7, 6.5))
    b = np.loadtxt(DATA / "buchner_exp_data.txt")
    b = b[np.argsort(b[:, 0])]
    ax.plot(b[:, 0], b[:, 1], "k.-", lw=0.8, label="Buchner (2002)")
    for (column, dx), out in outs.items():
        if column == "seed":
            p = np.genfromtxt(out / "pressure.csv", delimiter=",", names=True)
            t, raw = p["t_sqrt_g_over_H"], p["p_over_rho_g_H_at_02H"]
            line, = ax.plot(t, smoothed(t, raw, 0.1), lw=1.2, label=f"MPS, H/{round(1 / dx)}, smoothed over 0.1")
            ax.plot(t, raw, lw=0.3, alpha=0.3, color=line.get_color())
            lv = np.genfromtxt(out / "level.csv", delimiter=",", names=True)
            bx.plot(lv["t_sqrt_g_over_H"], lv["level_over_H_at_1653H"], lw=0.8, label=f"MPS, H/{round(1 / dx)}")
    ax.set_xlim(0, 6)
    ax.set_ylim(-0.2, 1.5)
    ax.set_xlabel("t sqrt(g/H)")
    ax.set_ylabel("p / (rho g H) at y = 0.2 H")
    ax.text(5.9, 1.38, "faint: every step", fontsize=8, ha="right")
    ax.legend(fontsize=8)
    ax.set_title("Seed column: downstream-wall pressure")
    bx.set_xlim(0, 6)
    bx.set_xlabel("t sqrt(g/H)")
    bx.set_ylabel("water level / H, 1.653 H from the wall")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "dambreak_pressure.png", dpi=120)


if __name__ == "__main__":
    main()
