#!/usr/bin/python3
"""Stability map of the classic dam-break column (a/20, to T = 3.5 in its 8a tank) over gamma x CFL, with and without
particle collisions, for the classic source (--pressure-treatment none) and the dam break's default (hs): stable (ran
to the end, front within 25 % of Martin & Moyce), inaccurate (ran, front further off), or blown up (stopped by the
guard, with the time it was stopped at). CSV + PNG.

  bench/dambreak_stability.py BUILD_DIR [--results bench/results] [--jobs 2]   (one thread per run; about 8 minutes)
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
COLLISIONS = [0.8, 0.0]
TREATMENTS = ["none", "hs"]
ACCURATE = 0.25


def run(exe, treatment, collision, cfl, gamma):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([str(exe), "--dx", repr(0.146 / 20), "--gamma", str(gamma), "--cfl", str(cfl),
                        "--collision", str(collision),
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
    row = {"pressure_treatment": treatment, "collision_l0": collision, "cfl": cfl, "gamma": gamma, "class": verdict,
           "front_error": error, "stopped_at_s": s["time_s"] if verdict == "blown up" else "", "steps": s["steps"],
           "reason": reason}
    print(row, flush=True)
    return row


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    exe = Path(args.build) / "apps" / "dambreak" / "dambreak"
    jobs = [(t, c, cfl, g) for t in TREATMENTS for c in COLLISIONS for cfl in CFLS for g in GAMMAS]
    with ThreadPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(lambda j: run(exe, *j), jobs))
    with open(results / "dambreak_stability.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    colours = {"stable": "tab:green", "inaccurate": "tab:orange", "blown up": "tab:red"}
    fig, axes = plt.subplots(len(TREATMENTS), len(COLLISIONS), figsize=(10, 4 * len(TREATMENTS)), sharey=True,
                             squeeze=False)
    for (ti, treatment), (ci, collision) in [(t, c) for t in enumerate(TREATMENTS) for c in enumerate(COLLISIONS)]:
        ax = axes[ti, ci]
        for r in rows:
            if r["collision_l0"] != collision or r["pressure_treatment"] != treatment:
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
        ax.set_title(f"source {treatment}, collisions {'at ' + str(collision) + ' l0' if collision else 'off'}")
    fig.suptitle("Classic dam break a/20 to T = 3.5: green ran with front within 25 % of Martin & Moyce, "
                 "orange ran, red stopped (time)", fontsize=9)
    fig.tight_layout()
    fig.savefig(results / "dambreak_stability.png", dpi=120)


if __name__ == "__main__":
    main()
