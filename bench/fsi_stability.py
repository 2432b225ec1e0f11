#!/usr/bin/python3
"""Where the partitioned coupling fails: the dam break on the plate (apps/fsi, l0 = 0.004, E = 6e6, to t = 0.3 s) over
the plate's density (solid/fluid ratio 0.5-10) x the fluid's CFL, with the load taken whole each step (relaxation 1)
and relaxed (0.1, the default), with the body's walls wet (mps::WetWalls, the default) and without, and with the
fluid's pressure gradient min-reference (the default) or conservative (exact action = reaction, wet walls only).

  bench/fsi_stability.py BUILD_DIR [--results bench/results] [--runs runs/fsi-stability] [--jobs 2] [--plot-only]
                         [--gradient min-reference|conservative|all] [--wet-walls both|true|false]

Writes fsi_stability.csv and fsi_stability.png (green: ran to the end, the label the largest tip displacement in mm;
red: stopped by a guard, the label the time). One OpenMP thread per run.
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

RATIOS = [0.5, 1.1, 2.0, 5.0, 10.0]
CFLS = [0.1, 0.2, 0.4]
RELAXATIONS = [1.0, 0.1]
WET_WALLS = ["false", "true"]
# (pressure gradient, wet walls) of each row of panels
SETTINGS = [("min-reference", "false"), ("min-reference", "true"), ("conservative", "true")]


def run(build, out, gradient, wet, ratio, cfl, relaxation):
    exe = Path(build) / "apps" / "fsi" / "fsi"
    cmd = [str(exe), "--density", repr(1000.0 * ratio), "--cfl", repr(cfl), "--relaxation", repr(relaxation),
           "--wet-walls", wet, "--pressure-gradient", gradient, "--end-time", "0.3", "--frames", "0",
           "--out", str(out)]
    subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    s = json.loads((out / "summary.json").read_text())
    return {"gradient": gradient, "wet_walls": wet, "ratio": ratio, "cfl": cfl, "relaxation": relaxation, "status": s["status"],
            "time_s": s["time_s"],
            "largest_tip_mm": 1e3 * s.get("checks", {}).get("largest_probe_ux_m", float("nan")),
            "error": s.get("error", "")}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--runs", default="runs/fsi-stability")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--wet-walls", choices=["both", "true", "false"], default="both",
                    help="run only one setting, keeping the other's rows of an existing CSV")
    ap.add_argument("--gradient", choices=["all", "min-reference", "conservative"], default="all",
                    help="run only one pressure gradient, keeping the other's rows of an existing CSV")
    a = ap.parse_args()
    results, runs = Path(a.results), Path(a.runs)
    results.mkdir(parents=True, exist_ok=True)
    old = []
    if (results / "fsi_stability.csv").exists():
        with open(results / "fsi_stability.csv") as f:
            old = [dict(r, gradient=r.get("gradient") or "min-reference", wet_walls=r.get("wet_walls") or "false", ratio=float(r["ratio"]), cfl=float(r["cfl"]),
                        relaxation=float(r["relaxation"]), time_s=float(r["time_s"]),
                        largest_tip_mm=float(r["largest_tip_mm"])) for r in csv.DictReader(f)]
    if a.plot_only:
        rows = old
    else:
        chosen = [(g, w) for g, w in SETTINGS if a.gradient in ("all", g) and a.wet_walls in ("both", w)]
        cases = [(g, w, r, c, x) for g, w in chosen for x in RELAXATIONS for r in RATIOS for c in CFLS]
        with ThreadPoolExecutor(max_workers=a.jobs) as pool:
            rows = list(pool.map(lambda k: run(a.build, runs / f"{k[0]}-wet{k[1]}-rho{k[2]}-cfl{k[3]}-relax{k[4]}",
                                               *k), cases))
        rows = [r for r in old if (r["gradient"], r["wet_walls"]) not in chosen] + rows
        with open(results / "fsi_stability.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    panels = [(g, w, x) for g, w in SETTINGS for x in RELAXATIONS
              if any((r["gradient"], r["wet_walls"]) == (g, w) for r in rows)]
    fig, axes = plt.subplots(len(panels) // 2, 2, figsize=(11, 3.6 * (len(panels) // 2)), sharey=True, squeeze=False)
    for ax, (gradient, wet, relaxation) in zip(axes.flat, panels):
        for r in rows:
            if r["relaxation"] != relaxation or r["wet_walls"] != wet or r["gradient"] != gradient:
                continue
            x, y = RATIOS.index(r["ratio"]), CFLS.index(r["cfl"])
            ok = r["status"] != "failed"
            ax.add_patch(plt.Rectangle((x - 0.45, y - 0.45), 0.9, 0.9, color="#7fc97f" if ok else "#f0027f", alpha=0.7))
            ax.text(x, y, f"{r['largest_tip_mm']:.1f} mm" if ok else f"t = {r['time_s']:.3f} s", ha="center",
                    va="center", fontsize=8)
        ax.set_xlim(-0.5, len(RATIOS) - 0.5)
        ax.set_ylim(-0.5, len(CFLS) - 0.5)
        ax.set_xticks(range(len(RATIOS)), [str(v) for v in RATIOS])
        ax.set_yticks(range(len(CFLS)), [str(v) for v in CFLS])
        ax.set_xlabel("plate density / water density")
        ax.set_title(f"{gradient}, load relaxation {relaxation:g}" + (" (taken whole)" if relaxation == 1 else "") +
                     (", wet walls" if wet == "true" else ", walls dry by the density test"), fontsize=9)
        ax.set_ylabel("fluid CFL")
    fig.suptitle("Dam break on an elastic plate (E = 6e6 Pa, l0 = 0.004 m, to 0.3 s): green ran (largest tip "
                 "displacement), red stopped", fontsize=9)
    fig.tight_layout()
    fig.savefig(results / "fsi_stability.png", dpi=120)


if __name__ == "__main__":
    main()
