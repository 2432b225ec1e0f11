"""Curves of the rotating app -> PNG.

usage: /usr/bin/python3 plot_rotating.py couette OUT.png RUN_DIR [RUN_DIR ...]   u_theta(r) against exact
       /usr/bin/python3 plot_rotating.py channel OUT.png [--reference CSV] RUN_DIR [RUN_DIR ...]
                                                   line 1, arc 2, barrel pressure
Each RUN_DIR is an --out directory (for --model both: OUT/moving and OUT/fixed); its name labels the curves.
--reference: a barrel pressure curve to draw with them (bench/results/rotating_reference.csv, the finite-difference
steady flow of bench/rotating_reference.py).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], [[float(v) for v in r] for r in rows[1:]]
    return header, [[r[k] for r in data] for k in range(len(header))]


def scene_of(run):
    """The run's geometry and Reynolds number from its summary.json (for --model both, from the folder above)."""
    for folder in (run, os.path.dirname(os.path.normpath(run))):
        path = os.path.join(folder, "summary.json")
        if os.path.isfile(path):
            with open(path) as f:
                p = json.load(f)["parameters"]
            return (f"R = {p['outer_radius_m']:g}, r = {p['inner_radius_m']:g}, {p['span_rad']:g} rad, "
                    f"omega = {p['omega_rad_per_s']:g} {p['sense'].split()[-1]}, Re = {p['re']:g}")
    return "parameters unknown: no summary.json"


def label(run):
    return os.path.basename(os.path.normpath(run))


def couette(out, runs):
    fig, (ax, ae) = plt.subplots(1, 2, figsize=(8, 3.4))
    for run in runs:
        header, cols = read(os.path.join(run, "couette.csv"))
        k = len(header) - 2  # the last time: u, then exact
        t = header[k].split("_t")[-1]
        ax.plot(cols[0], cols[k], "o", ms=3, label=f"{label(run)}, t = {t} s")
        ae.plot(cols[0], [u - e for u, e in zip(cols[k], cols[k + 1])], "o-", ms=3, label=label(run))
        ax.plot(cols[0], cols[k + 1], "k-", lw=0.8)
    ax.set_xlabel("r")
    ax.set_ylabel("u_theta (line: exact A r + B/r)")
    ae.set_xlabel("r")
    ae.set_ylabel("u_theta - exact  [omega R1]")
    ae.axhline(0, color="k", lw=0.5)
    ax.legend(fontsize=7)
    ae.legend(fontsize=7)
    fig.suptitle("Taylor-Couette, inner cylinder r = 1 at omega = 1, outer r = 2 at rest", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=100)


def channel(out, runs):
    reference = None
    if runs and runs[0] == "--reference":
        reference, runs = read(runs[1])[1], runs[2:]
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    files = [("line1.csv", "r (line 1, channel centre line)", "u_theta,rel / (omega R)"),
             ("arc2.csv", "phi [rad] (arc 2, r = 1.5)", "u_r,rel / (omega R)"),
             ("barrel_pressure.csv", "phi [rad] (barrel inner wall)", "p - mean over |phi| <= 0.4")]
    styles = ["o", "s", "^", "v", "d"]
    for ax, (name, xl, yl) in zip(axes, files):
        for i, run in enumerate(runs):
            header, cols = read(os.path.join(run, name))
            for k in range(1, len(header)):
                t = header[k].split("_t")[-1]
                ax.plot(cols[0], cols[k], styles[i % len(styles)] + ("-" if k == len(header) - 1 else ":"), ms=2.5,
                        lw=0.7, label=f"{label(run)}, t = {t} s")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        if name == "barrel_pressure.csv" and reference:
            ax.plot(reference[0], reference[1], "k-", lw=1.0, label="finite differences, steady, Re = 2")
            ax.legend(fontsize=7)
        if name == "barrel_pressure.csv":  # the corner values, hundreds, would flatten the rest
            inner = [v for run in runs for h, c in [read(os.path.join(run, name))] for k in range(1, len(h))
                     for x, v in zip(c[0], c[k]) if abs(x) <= 0.45 and v == v]
            if inner:
                ax.set_ylim(1.3 * min(inner), 1.3 * max(inner))
            ax.set_title("corners (|phi| > 0.45) off scale", fontsize=8)
        ax.axhline(0, color="k", lw=0.4)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Screw channel ({scene_of(runs[0])}): relative velocity and barrel pressure in the channel frame",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    {"couette": couette, "channel": channel}[sys.argv[1]](sys.argv[2], sys.argv[3:])
