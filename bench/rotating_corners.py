"""Corner study for seed 000's screw channel: barrel-wall pressure near the two corners where barrel meets
flights, for each gamma of the mixed PPE source, each pressure gradient and with and without particle shifting
(the corrective matrix and shifting are the corrections on offer). Runs the rotating app once per setting, then
writes a CSV and a PNG chart.

usage: /usr/bin/python3 bench/rotating_corners.py --app build/release/apps/rotating/rotating
           [--across 24] [--model moving] [--time 0.5] --out bench/results/rotating_corners.csv

Per run, from barrel_pressure.csv at the last time (p less its mean over |phi| <= 0.4, averaged over the last
half of the run):
  tv_over_range    total variation of p over |phi| <= 0.4 divided by its range there: 1 for a monotone
                   curve, larger the more it wiggles;
  sign_changes     sign changes of the second difference of p over |phi| <= 0.4 (away from the corners);
  corner_low/high  p at the barrel wall particle nearest the upstream (phi < 0) and downstream corner, just
                   inside the opening;
  odd_defect       max |p(phi) + p(-phi)| over |phi| <= 0.4 divided by the range (the symmetry test's 10 %);
  status           ran, or the guard's stop.
"""
import argparse
import csv
import json
import os
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

GAMMAS = [0.0, 0.01, 0.05, 0.5, 0.99, 1.0]
# (gradient, shifting coefficient A); the scene's default is the last.
SETTINGS = [("min-reference", 0.0), ("corrected-min-reference", 0.0), ("min-reference", 1.0),
            ("corrected-min-reference", 1.0)]


def label(grad, shift):
    gradient = "min-reference" if grad == "min-reference" else "corrective matrix"
    return gradient + (f" + shifting {shift:g}" if shift else "")


def measures(path, limit=0.4):
    with open(path) as f:
        rows = list(csv.reader(f))
    data = [(float(r[0]), float(r[-1])) for r in rows[1:] if r[-1] != "nan"]
    inner = [p for phi, p in data if abs(phi) <= limit]
    rng = max(inner) - min(inner)
    tv = sum(abs(b - a) for a, b in zip(inner, inner[1:]))
    d2 = [inner[k - 1] - 2 * inner[k] + inner[k + 1] for k in range(1, len(inner) - 1)]
    changes = sum(1 for a, b in zip(d2, d2[1:]) if a * b < 0)
    opening = [(phi, p) for phi, p in data if abs(phi) < 0.5]
    return {"range": rng, "tv_over_range": tv / rng if rng > 0 else float("nan"), "sign_changes": changes,
            "second_differences": len(d2), "corner_low": opening[0][1], "corner_high": opening[-1][1]}, data


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--app", required=True)
    ap.add_argument("--across", type=int, default=24)
    ap.add_argument("--model", default="moving")
    ap.add_argument("--time", type=float, default=0.5)
    ap.add_argument("--runs", default="runs/rotating_corners")
    ap.add_argument("--out", default="bench/results/rotating_corners.csv")
    a = ap.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
    rows, curves = [], {}
    for grad, shift in SETTINGS:
        for g in GAMMAS:
            run = os.path.join(a.runs, f"{grad}_s{shift:g}_g{g}")
            cmd = [a.app, "--scene", "channel", "--model", a.model, "--across", str(a.across), "--gamma", str(g),
                   "--gradient", grad, "--shifting", str(shift), "--times", str(a.time), "--average", "0.5",
                   "--frames", "0", "--out", run]
            print(" ".join(cmd), flush=True)
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
            with open(os.path.join(run, "summary.json")) as f:
                summary = json.load(f)
            row = {"gradient": grad, "shifting": shift, "gamma": g, "across": a.across, "model": a.model,
                   "time_s": summary["time_s"], "steps": summary["steps"]}
            if proc.returncode == 1:
                row.update(status="stopped: " + summary.get("error", "")[:160].replace(",", ";"))
            else:
                m, data = measures(os.path.join(run, "barrel_pressure.csv"))
                row.update(status="ran", **m)
                row["odd_defect"] = summary["checks"]["barrel_pressure_odd_defect_over_range"]
                row["arc2_odd_defect"] = summary["checks"]["arc2_odd_defect_over_omega_R2"]
                row["seconds"] = summary["timings"]["total_s"]
                curves[(grad, shift, g)] = data
            print("  ", {k: row[k] for k in row if k not in ("gradient", "shifting", "model")}, flush=True)
            rows.append(row)
    keys = ["gradient", "shifting", "gamma", "across", "model", "status", "time_s", "steps", "range", "tv_over_range",
            "sign_changes", "second_differences", "odd_defect", "corner_low", "corner_high", "arc2_odd_defect", "seconds"]
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    fig, (ac, ab, ao) = plt.subplots(1, 3, figsize=(15, 4.2))
    styles = {SETTINGS[0]: "-", SETTINGS[1]: "--", SETTINGS[2]: ":", SETTINGS[3]: "-"}
    for (grad, shift, g), data in curves.items():
        if g not in (0.01, 1.0):  # the curves of the other gammas lie between
            continue
        inside = [d for d in data if abs(d[0]) < 0.5]
        ac.plot([d[0] for d in inside], [d[1] for d in inside], styles[(grad, shift)],
                lw=1.6 if (grad, shift) == SETTINGS[-1] else 0.8, label=f"gamma {g}, {label(grad, shift)}")
    ac.set_xlabel("phi [rad] (barrel inner wall; flights at +-0.5)")
    ac.set_ylabel("p - mean over |phi| <= 0.4")
    ac.set_ylim(-80, 80)
    ac.legend(fontsize=6)
    width = 0.8 / len(SETTINGS)
    for i, setting in enumerate(SETTINGS):
        xs, tv, odd, labels = [], [], [], []
        for k, g in enumerate(GAMMAS):
            r = next(r for r in rows if (r["gradient"], r["shifting"]) == setting and r["gamma"] == g)
            xs.append(k + (i - 0.5 * (len(SETTINGS) - 1)) * width)
            ran = r["status"] == "ran"
            tv.append(r["tv_over_range"] if ran else 0)
            odd.append(r["odd_defect"] if ran else float("nan"))
            labels.append(f"{r['sign_changes']}" if ran else "x")
        bars = ab.bar(xs, tv, width, label=label(*setting))
        for b, t in zip(bars, labels):
            ab.annotate(t, (b.get_x() + b.get_width() / 2, b.get_height()), ha="center", va="bottom", fontsize=5)
        ao.bar(xs, odd, width, label=label(*setting))
    for ax in (ab, ao):
        ax.set_xticks(range(len(GAMMAS)), [str(g) for g in GAMMAS])
        ax.legend(fontsize=6)
    ab.set_xlabel("gamma (on bars: sign changes of the 2nd difference; x: stopped by the guard)")
    ab.set_ylabel("total variation / range, |phi| <= 0.4 (1: monotone)")
    ao.axhline(0.1, color="k", lw=0.6)
    ao.set_yscale("log")
    ao.set_xlabel("gamma (missing bar: stopped by the guard)")
    ao.set_ylabel("odd defect / range, |phi| <= 0.4 (test: <= 0.1)")
    fig.suptitle(f"Barrel pressure near the corners, {a.model} model, {a.across} across, t = {a.time} s", fontsize=9)
    fig.tight_layout()
    png = os.path.splitext(a.out)[0] + ".png"
    fig.savefig(png, dpi=90)
    print("wrote", a.out, png)


if __name__ == "__main__":
    sys.exit(main())
