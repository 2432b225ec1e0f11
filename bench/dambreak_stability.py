#!/usr/bin/python3
"""Stability map of the classic dam-break column (a/20 unless --across, to T = 3.5 in its 8a tank) over gamma x CFL for four settings:
the classic source and the higher-order source (hs) with collisions at 0.8 l0 and the asymmetry test at 0.9 (hs so was
the dam break's default before the dynamic stabilisation), hs with neither, and today's default hs+ds with neither.
Each run is stable (ran to the end, front within 25 % of Martin & Moyce), inaccurate (ran, front further off), or
blown up (stopped by the guard, with the time it was stopped at). CSV + PNG.

  bench/dambreak_stability.py BUILD_DIR [--results bench/results] [--jobs 2] [--across 20] [--name dambreak_stability]
                              [--settings 0,1,2,3]
  (one thread per run; about 12 minutes at a/20)
  bench/dambreak_stability.py BUILD_DIR --across 40 --settings 1,3 --name dambreak_stability_a40   (the old default
  beside the new at the default spacing)
"""
import argparse
import csv
import json
import os
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

GAMMAS = [0.01, 0.1, 0.5, 0.99]
CFLS = [0.05, 0.1, 0.2, 0.4, 0.8]
# (treatment, collision distance in l0, asymmetry fraction)
SETTINGS = [("none", 0.8, 0.9), ("hs", 0.8, 0.9), ("hs", 0.0, 0.0), ("hs+ds", 0.0, 0.0)]
ACCURATE = 0.25


def run(exe, across, treatment, collision, asymmetry, cfl, gamma):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([str(exe), "--dx", repr(0.146 / across), "--gamma", str(gamma), "--cfl", str(cfl),
                        "--collision", str(collision), "--asymmetry", str(asymmetry),
                        "--pressure-treatment", treatment, "--frames", "0", "--out", out], capture_output=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
        s = json.loads((Path(out) / "summary.json").read_text())
    c = s.get("checks", {})
    errors = [c[k] for k in ("martin_moyce_1_front_max_error", "martin_moyce_2_front_max_error") if k in c]
    error = min(errors) if errors else ""
    if s["status"] == "failed":
        verdict = "blown up"
    else:
        verdict = "stable" if error != "" and error <= ACCURATE else "inaccurate"
    reason = s.get("error", "").split("): ")[-1].split(" (reduce")[0]
    row = {"across": across, "pressure_treatment": treatment, "collision_l0": collision, "asymmetry": asymmetry, "cfl": cfl, "gamma": gamma, "class": verdict,
           "front_error": error, "stopped_at_s": s["time_s"] if verdict == "blown up" else "", "steps": s["steps"],
           "reason": reason}
    print(row, flush=True)
    return row


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--across", type=int, default=20, help="particles across the column's width a")
    ap.add_argument("--name", default="dambreak_stability", help="the CSV's and the chart's name in --results")
    ap.add_argument("--settings", default="0,1,2,3", help="which of SETTINGS to run, by index (e.g. 1,3: the old "
                    "default and the new)")
    args = ap.parse_args()
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    exe = Path(args.build) / "apps" / "dambreak" / "dambreak"
    settings = [SETTINGS[int(k)] for k in args.settings.split(",")]
    jobs = [(*setting, cfl, g) for setting in settings for cfl in CFLS for g in GAMMAS]
    with ThreadPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(lambda j: run(exe, args.across, *j), jobs))
    with open(results / f"{args.name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    colours = {"stable": "tab:green", "inaccurate": "tab:orange", "blown up": "tab:red"}
    rows_of_panels = (len(settings) + 1) // 2
    fig, axes = plt.subplots(rows_of_panels, 2, figsize=(10, 4 * rows_of_panels), sharey=True, squeeze=False)
    for ax, (treatment, collision, asymmetry) in zip(axes.flat, settings):
        for r in rows:
            if (r["pressure_treatment"], r["collision_l0"], r["asymmetry"]) != (treatment, collision, asymmetry):
                continue
            x, y = GAMMAS.index(r["gamma"]), CFLS.index(r["cfl"])
            ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), 1, 1, color=colours[r["class"]]))
            label = f"{100 * r['front_error']:.0f} %" if r["class"] != "blown up" else f"t={r['stopped_at_s']:.3f}"
            ax.text(x, y, label, ha="center", va="center", fontsize=8)
        ax.set_xlim(-0.5, len(GAMMAS) - 0.5)
        ax.set_ylim(-0.5, len(CFLS) - 0.5)
        ax.set_xticks(range(len(GAMMAS)), [str(g) for g in GAMMAS])
        ax.set_yticks(range(len(CFLS)), [str(c) for c in CFLS])
        ax.set_xlabel("gamma")
        ax.set_ylabel("CFL")
        ax.set_title(f"{treatment}, " + (f"collisions at {collision} l0, asymmetry {asymmetry}" if collision
                                         else "no collisions, no asymmetry test"), fontsize=9)
    fig.suptitle(f"Classic dam break a/{args.across} to T = 3.5: green ran with front within 25 % of Martin & Moyce, "
                 "orange ran, red stopped (time)", fontsize=9)
    fig.tight_layout()
    fig.savefig(results / f"{args.name}.png", dpi=120)


if __name__ == "__main__":
    main()
