#!/usr/bin/python3
"""When the SPHERIC Test 2 record's clock starts (docs/dambreak3d.md): the water level at H4, inside the column, falls
from the release on, long before the front meets anything, so its record fixes the release time on the record's clock.
SPHERIC Test 2's column (1.228 m long, 0.55 m high) collapses without the box as a 2-D run with the 3-D dam break's
numerics (apps/dambreak's 3-D defaults: no shifting) at each spacing, with the default pressure gradient
(min-reference) and with the corrective matrix (corrected-min-reference); H4 is read as the app reads it (the top of the
fluid standing on the floor within l0 of the gauge, plus l0/2) every 0.01 s to 0.45 s. The delay is the shift of the
record's clock that brings the record's H4 closest to the run's over 0.1-0.4 s (mean absolute difference, searched in
steps of 1 ms): the run's H4 at t against the record's at t - delay. The 3-D dam break's runs given with --runs3d get
the same fit from their level.csv, and their P1 arrival (summary.json) is set beside the record's 0.394 s on the
record's clock and on the clock moved by the delay. Writes bench/results/spheric2_clock.csv and spheric2_clock.png.

  bench/spheric2_clock.py BUILD_DIR [--spacings 0.05,0.025,0.0125,0.00625]
                          [--gradients min-reference,corrected-min-reference] [--runs3d DIR,DIR]
                          [--fields '{"gamma": 0.1}'] [--name spheric2_clock]

One thread; a 2-D run at 0.00625 m takes about 3.5 minutes.
"""
import argparse
import csv
import json
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
import spheric2_front as front  # noqa: E402  the column, its tank and its numerics

H4_FROM_BACK_WALL = 3.22 - 2.638  # [m] the record's H4, from the tank's wall behind the column
RECORD = ROOT / "data" / "dambreak" / "spheric2_p1_h2_h4.csv"
FIT_WINDOW = (0.1, 0.4)           # [s] before H4 meets any wave reflected from the box or a wall
GAUGE_FLOOR_REACH, GAUGE_GAP = 1.5, 2.0  # [l0] as mps::water_level's wire (lib/mps/io/probes.cpp)


def record():
    r = np.genfromtxt(RECORD, delimiter=",", names=True)
    return r["time_s"], r["H4_m"]


def water_height(z_on_line, l0):
    """The app's gauge: from the lowest fluid on the floor up through layers no more than GAUGE_GAP l0 apart."""
    z = np.sort(z_on_line)
    if len(z) == 0 or z[0] > GAUGE_FLOOR_REACH * l0:
        return 0.0
    top = z[0]
    for v in z:
        if v - top > GAUGE_GAP * l0:
            break
        top = v
    return top + 0.5 * l0


def collapse_2d(sps, l0, end_time=0.45, gradient="min-reference", **fields):
    """The 2-D column's H4 every 0.01 s: [(t, H4)] from t = 0 (the column mirrored: its back wall at x = 0).
    `fields`: SimulationConfig fields over the dam break's."""
    sim = front.simulation(sps, 2, l0, 0.8, shifting=0.0, pressure_gradient=gradient, **fields)
    samples = []
    for k in range(0, round(end_time / 0.01) + 1):
        if k:
            sim.run(end_time=0.01 * k)
        p = sim.particles
        fluid = p.kind == sps.Kind.fluid.value
        r = p.positions[fluid]
        samples.append((sim.time, water_height(r[np.abs(r[:, 0] - H4_FROM_BACK_WALL) < l0, 1], l0)))
    return np.array(samples)


def delay(t, h4, column_height=front.HEIGHT):
    """(delay [s], mean |H4 - record| after the shift [m], the same without it [m]). A run whose column stands higher
    or lower than 0.55 m on its lattice has its H4 moved by the difference first."""
    rt, rh = record()
    h4 = h4 - (column_height - front.HEIGHT)
    inside = (t >= FIT_WINDOW[0]) & (t <= FIT_WINDOW[1])

    def mismatch(d):
        return float(np.mean(np.abs(np.interp(t[inside] - d, rt, rh) - h4[inside])))

    shifts = np.arange(-0.05, 0.2, 0.001)
    best = min(shifts, key=mismatch)
    return float(best), mismatch(best), mismatch(0.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("--spacings", default="0.05,0.025,0.0125,0.00625")
    ap.add_argument("--gradients", default="min-reference,corrected-min-reference",
                    help="the 2-D runs' pressure gradients (--gradient of the app; the first is its default)")
    ap.add_argument("--runs3d", default="", help="3-D dam break output folders (level.csv, summary.json)")
    ap.add_argument("--fields", default="{}", help="SimulationConfig fields for the 2-D runs, as JSON")
    ap.add_argument("--name", default="spheric2_clock", help="the results' file name in bench/results/")
    args = ap.parse_args()
    os.environ["OMP_NUM_THREADS"] = "1"
    sys.path.insert(0, str(Path(args.build) / "python"))
    import sparsemps as sps

    rows, curves = [], []
    for gradient, l0 in [(g, float(l)) for g in args.gradients.split(",") for l in args.spacings.split(",")]:
        s = collapse_2d(sps, l0, gradient=gradient, **json.loads(args.fields))
        d, fitted, raw = delay(s[:, 0], s[:, 1])
        rows.append({"run": "2-D collapse", "gradient": gradient, "fields": args.fields, "l0_m": l0,
                     "column_height_m": front.HEIGHT,
                     "delay_s": f"{d:.3f}",
                     "h4_mean_error_shifted_m": f"{fitted:.4f}", "h4_mean_error_m": f"{raw:.4f}",
                     "p1_arrival_s": "", "p1_arrival_error": "", "p1_arrival_error_after_delay": ""})
        curves.append((f"2-D, l0 = {l0:g} m{'' if gradient == 'min-reference' else ', ' + gradient}", s[:, 0],
                       s[:, 1], d, "-" if gradient == "min-reference" else ":"))
        print(rows[-1], flush=True)
    for folder in filter(None, args.runs3d.split(",")):
        level = np.genfromtxt(Path(folder) / "level.csv", delimiter=",", names=True)
        summary = json.loads((Path(folder) / "summary.json").read_text())
        parameters = summary["parameters"]
        l0, height = parameters["dx_m"], parameters["column_m"][2]  # the column as its lattice holds it
        d, fitted, raw = delay(level["time_s"], level["H4_m"], height)
        arrival, record_arrival = summary["checks"]["p1_arrival_s"], summary["checks"]["p1_arrival_record_s"]
        gradient = parameters["gradient"]
        rows.append({"run": "3-D dam break", "gradient": gradient, "fields": "", "l0_m": l0,
                     "column_height_m": round(height, 6),
                     "delay_s": f"{d:.3f}",
                     "h4_mean_error_shifted_m": f"{fitted:.4f}", "h4_mean_error_m": f"{raw:.4f}",
                     "p1_arrival_s": f"{arrival:.4f}", "p1_arrival_error": f"{arrival / record_arrival - 1:+.3f}",
                     "p1_arrival_error_after_delay": f"{(arrival - d) / record_arrival - 1:+.3f}"})
        curves.append((f"3-D dam break, l0 = {l0:g} m{'' if gradient == 'min-reference' else ', ' + gradient}",
                       level["time_s"], level["H4_m"] - (height - front.HEIGHT), d, "--"))
        print(rows[-1], flush=True)

    out = ROOT / "bench" / "results"
    with (out / f"{args.name}.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rt, rh = record()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6), gridspec_kw={"width_ratios": [1, 1, 0.62]})
    families = {}  # one colour map a family (dimensions and gradient), darker for finer spacings
    for label, *_ in curves:
        families.setdefault(label.split(", l0")[0] + ("c" if "corrected" in label else ""), []).append(label)
    maps = iter(["Blues", "Greens", "Reds", "Purples", "Oranges", "Greys"])
    colour = {}
    for members in families.values():
        cmap = plt.get_cmap(next(maps))
        for k, label in enumerate(members):
            colour[label] = cmap(0.45 + 0.55 * k / max(1, len(members) - 1))
    for ax, moved in zip(axes[:2], (False, True)):
        keep = rt <= 0.5
        ax.plot(rt[keep], rh[keep], color="0.55", lw=0.8, label="experiment (Kleefsman et al. 2005)")
        for label, t, h, d, style in curves:
            inside = t <= 0.5
            ax.plot(t[inside] - (d if moved else 0.0), h[inside], style, color=colour[label], lw=1.2,
                    label=label + f", delay {d * 1000:.0f} ms")
        ax.set_xlabel("t on the record's clock [s]")
        ax.set_title("runs moved by their delay" if moved else "as run (release at t = 0)")
        ax.grid(alpha=0.3)
        ax.set_xlim(0, 0.45)
        ax.set_ylim(0.43, 0.555)
    axes[0].set_ylabel("H4, water level inside the column [m]")
    axes[2].axis("off")
    axes[2].legend(*axes[1].get_legend_handles_labels(), loc="center left", fontsize=7, frameon=False)
    fig.suptitle("SPHERIC Test 2: the column's level at H4 against the record")
    fig.tight_layout()
    fig.savefig(out / f"{args.name}.png", dpi=120)
    print(f"wrote {out / args.name}.csv and {args.name}.png")


if __name__ == "__main__":
    main()
