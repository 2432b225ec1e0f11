#!/usr/bin/python3
"""Charts of the acoustic studies and the pressure-map panel of docs/acoustics.md.

  plot_acoustic.py cfl     bench/results/acoustic_cfl.csv     bench/results/acoustic_cfl.png
  plot_acoustic.py spacing bench/results/acoustic_spacing.csv bench/results/acoustic_spacing.png
  plot_acoustic.py maps       RUNS_DIR                        bench/results/acoustic_maps.png
  plot_acoustic.py centreline RUNS_DIR                        bench/results/acoustic_centreline.png
      (RUNS_DIR holds the app's outputs of every case at its defaults: RUNS_DIR/<case>/summary.json,
       centerline.csv and maps/)
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LinearSegmentedColormap  # noqa: E402

TIMES = ["0.025", "0.05", "0.1"]
MARKERS = {"0.025": "s", "0.05": "^", "0.1": "o"}
# The app's diverging palette (apps/acoustic/png.cpp), for the colour bar of the map panel.
PALETTE = LinearSegmentedColormap.from_list(
    "acoustic", [np.array(c) / 255 for c in [(5, 48, 97), (67, 147, 195), (247, 247, 247), (214, 96, 77), (103, 0, 31)]])


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def cfl_chart(rows, out):
    fig, (ax, st) = plt.subplots(2, 1, figsize=(8.2, 7.4), sharex=True, gridspec_kw={"height_ratios": [2.2, 1]})
    # Errors: the three MPS variants agree to 1e-9 wherever they are all stable (the pulse has not reached the
    # walls by 0.1 s), so one MPS curve is drawn: the hard-wall one, which is stable furthest.
    for (gradient, boundary), colour, label in ((("mps", "hard"), "C0", "MPS gradient (seed 001)"),
                                                (("ls3", "mur"), "C3", "least-squares cubic (ls3)")):
        sel = sorted([r for r in rows if r["gradient"] == gradient and r["boundary"] == boundary], key=lambda r: float(r["cfl"]))
        for t in TIMES:
            pts = [(float(r["cfl"]), float(r[f"error_t{t}"])) for r in sel if r[f"error_t{t}"] and r["status"] == "stable"]
            if pts:
                x, y = zip(*pts)
                ax.plot(x, y, marker=MARKERS[t], color=colour, ms=4, lw=1, ls="-" if t == "0.1" else ":",
                        label=f"{label}, t = {t} s")
    ax.set_yscale("log")
    ax.set_ylabel("relative RMS error of dp\n(interior particles, stable runs)")
    ax.set_title("Gaussian pulse b = 3 m, l0 = 0.5 m: error and stability vs CFL (seed 001 Fig. 2)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left")
    # Stability: each configuration run for >= 2000 steps; x = stopped by the guard (at the step written beside).
    configs = [("mps", "hard"), ("mps", "mur"), ("mps", "mur-step"), ("ls3", "mur")]
    names = {("mps", "hard"): "MPS, hard walls", ("mps", "mur"): "MPS, Mur every stage",
             ("mps", "mur-step"): "MPS, Mur once per step\n(as published)", ("ls3", "mur"): "ls3, Mur every stage"}
    for k, cfg in enumerate(configs):
        sel = sorted([r for r in rows if (r["gradient"], r["boundary"]) == cfg], key=lambda r: float(r["cfl"]))
        first_unstable = next((r for r in sel if r["status"] != "stable"), None)
        for r in sel:
            c = float(r["cfl"])
            if r["status"] == "stable":
                st.plot(c, k, "o", color="C2", ms=5)
            else:
                st.plot(c, k, "x", color="C3", ms=7, mew=2)
        if first_unstable:
            st.text(float(first_unstable["cfl"]) * 0.97, k + 0.3, f"CFL {first_unstable['cfl']}: guard at step {first_unstable['steps']}",
                    fontsize=6.5, ha="right", color="C3")
        if sel:
            limit = float(sel[0]["stable_cfl_estimate"])
            st.plot([limit, limit], [k - 0.35, k + 0.35], color="k", lw=1.2, ls="--")
    for a in (ax, st):
        for limit, colour in ((2.712, "C0"), (1.458, "C3")):
            a.axvline(limit, color=colour, lw=0.6, ls=":")
    st.plot([], [], "o", color="C2", label="stable for 2000 steps")
    st.plot([], [], "x", color="C3", mew=2, label="stopped by the guard (step)")
    st.plot([], [], "k--", label="RK4 limit, von Neumann")
    st.set_yticks(range(len(configs)), [names[c] for c in configs], fontsize=7)
    st.set_ylim(-0.6, len(configs) - 0.4)
    st.invert_yaxis()
    st.set_xscale("log")
    st.set_xlabel("CFL = c0 dt / l0")
    st.grid(True, axis="x", which="both", alpha=0.3)
    st.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=3, frameon=False)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


def spacing_chart(rows, out):
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for gradient, colour, label, order in (("mps", "C0", "MPS gradient (seed 001)", 2), ("ls3", "C3", "least-squares cubic (ls3)", 4)):
        sel = sorted([r for r in rows if r["gradient"] == gradient], key=lambda r: float(r["l0_m"]))
        for t in TIMES:
            pts = [(float(r["l0_m"]), float(r[f"error_t{t}"])) for r in sel if r[f"error_t{t}"]]
            x, y = zip(*pts)
            ax.plot(x, y, marker=MARKERS[t], color=colour, ms=4, lw=1, ls="-" if t == "0.1" else ":",
                    label=f"{label}, t = {t} s")
        # A reference slope below the finest point at t = 0.1 s.
        pts = [(float(r["l0_m"]), float(r["error_t0.1"])) for r in sel if r["error_t0.1"]]
        x0, y0 = pts[0]
        xs = np.array([x0, 4 * x0])
        ax.plot(xs, 0.3 * y0 * (xs / x0) ** order, color=colour, lw=1.2, ls="--", label=f"slope {order}")
    ax.axhline(0.005, color="k", lw=0.8, ls="-.", label="target 0.5 %")
    ax.axvline(0.25, color="grey", lw=0.8)
    ax.text(0.26, 0.02, "paper's l0", color="grey", ha="left", va="bottom", fontsize=7, transform=ax.get_xaxis_transform())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particle spacing l0 [m]")
    ax.set_ylabel("relative RMS error of dp (interior particles)")
    ax.set_title("Gaussian pulse b = 3 m, CFL = 0.17: error vs spacing (seed 001 Fig. 3)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


def maps_panel(runs, out):
    panels = [("free", 0.1), ("two-pulse", 0.1), ("flow", 0.02), ("hard", 0.15), ("mur", 0.15), ("flow", 0.1)]
    fig, axes = plt.subplots(2, 3, figsize=(10.5, 7.4))
    for ax, (case, t) in zip(axes.flat, panels):
        with open(os.path.join(runs, case, "summary.json")) as f:
            s = json.load(f)
        m = min(s["maps"], key=lambda m: abs(m["time_s"] - t))
        err = min(s["samples"], key=lambda x: abs(x["time_s"] - t))
        img = plt.imread(os.path.join(runs, case, m["file"]))
        box = s["parameters"]["box_m"]
        ax.imshow(img, extent=[box[0], box[2], box[1], box[3]], interpolation="nearest")
        rng = m["range_pa"]
        sub = f"error {100 * err['relative_rms_error']:.2f} %" if abs(err["time_s"] - t) < 1e-6 else ""
        ax.set_title(f"{case}, t = {m['time_s']:.2f} s\n|dp| <= {rng:.3f} Pa   {sub}", fontsize=9)
        ax.tick_params(labelsize=7)
        sm = plt.cm.ScalarMappable(cmap=PALETTE, norm=plt.Normalize(-rng, rng))
        fig.colorbar(sm, ax=ax, fraction=0.046, pad=0.02).ax.tick_params(labelsize=6)
    p = s["parameters"]
    fig.suptitle(f"MPS-WP pressure maps: l0 = {p['l0_m']} m, CFL = {p['cfl']}, b = {p['pulse']['b_m']} m, "
                 f"{p['gradient']} gradient (x, y in m)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=72)


def centreline_panel(runs, out):
    panels = [("free", 0.1), ("two-pulse", 0.1), ("flow", 0.02), ("hard", 0.2), ("mur", 0.15), ("flow", 0.1)]
    fig, axes = plt.subplots(2, 3, figsize=(11, 6.2))
    for ax, (case, t) in zip(axes.flat, panels):
        rows = read(os.path.join(runs, case, "centerline.csv"))
        tag = f"{t:.4f}"
        x = np.array([float(r["x_m"]) for r in rows])
        num = np.array([float(r[f"dp_t{tag}"]) for r in rows])
        ex = np.array([float(r[f"exact_t{tag}"]) for r in rows])
        err = np.sqrt(np.sum((num - ex) ** 2) / np.sum(ex ** 2))
        ax.plot(x, ex, "k-", lw=1.6, label="exact")
        ax.plot(x, num, "C3--", lw=1.1, label="MPS-WP")
        ax.set_title(f"{case}, t = {t} s (centreline error {100 * err:.2f} %)", fontsize=9)
        ax.set_xlabel("x [m] (row nearest y = 0)", fontsize=8)
        ax.set_ylabel("dp [Pa]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    with open(os.path.join(runs, "free", "summary.json")) as f:
        p = json.load(f)["parameters"]
    fig.suptitle(f"dp along y = 0 against the exact solution: l0 = {p['l0_m']} m, CFL = {p['cfl']}, "
                 f"b = {p['pulse']['b_m']} m, {p['gradient']} gradient (seed 001 Fig. 5, 7, 9, 11, 14)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=80)


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("cfl", "spacing", "maps", "centreline"):
        sys.exit(__doc__)
    kind, src, out = sys.argv[1:]
    if kind == "cfl":
        cfl_chart(read(src), out)
    elif kind == "spacing":
        spacing_chart(read(src), out)
    elif kind == "maps":
        maps_panel(src, out)
    else:
        centreline_panel(src, out)
    print("wrote " + out)


if __name__ == "__main__":
    main()
