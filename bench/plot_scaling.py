#!/usr/bin/python3
"""Per-step cost against N from bench_scaling's CSV: one log-log panel per solver run (phases and total, with
fitted slopes of log time against log N) and one of particle-steps per second.

    plot_scaling.py bench/results/scaling.csv bench/results/scaling.png
"""
import csv
import datetime
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import stamp

PHASES = [("neighbors_s", "neighbours"), ("assemble_s", "assembly"), ("setup_s", "solver setup"),
          ("solve_s", "solve"), ("rest_s", "rest (predictor, corrector)"), ("total_s", "total")]


def slope(n, t):
    n, t = np.asarray(n, float), np.asarray(t, float)
    ok = t > 0
    if ok.sum() < 2:
        return float("nan")
    return np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)[0]


def main(src, dst):
    runs = {}
    with open(src) as f:
        for row in csv.DictReader(f):
            label = row["solver"] + ("" if row["warm_start"] == "1" else " (zero initial guess)")
            r = {k: float(v) for k, v in row.items() if k not in ("solver", "warm_start", "solver_spec")}
            r["rest_s"] = r["predict_s"] + r["correct_s"]
            runs.setdefault(label, []).append(r)
    labels = list(runs)
    cols = 4  # two rows for up to seven panels
    nrows = -(-(len(labels) + 1) // cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 4.0 * nrows), squeeze=False)
    axes = axes.ravel()
    for ax in axes[len(labels) + 1:]:
        ax.set_visible(False)
    for ax, label in zip(axes, labels):
        rows = sorted(runs[label], key=lambda r: r["fluid"])
        n = [r["fluid"] for r in rows]
        for key, name in PHASES:
            t = [r[key] for r in rows]
            if max(t) <= 0:
                continue
            style = dict(color="k", lw=2) if key == "total_s" else {}
            ax.loglog(n, t, "o-", ms=3, label=f"{name}: slope {slope(n, t):.2f}", **style)
        ax.set_title(label, fontsize=8)
        ax.set_xlabel("fluid particles N")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[:len(labels):cols]:
        ax.set_ylabel("seconds per step")
    ax = axes[len(labels)]
    for label in labels:
        rows = sorted(runs[label], key=lambda r: r["fluid"])
        ax.loglog([r["fluid"] for r in rows], [r["particle_steps_per_s"] for r in rows], "o-", ms=3, label=label)
    ax.set_title("particle-steps per second", fontsize=8)
    ax.set_xlabel("fluid particles N")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    threads = ", ".join(sorted({f"{r['threads']:.0f}" for rows in runs.values() for r in rows}))
    fig.suptitle(f"SparseMPS per-step cost, body-force channel (bench_scaling); {stamp.machine()}, OpenMP threads: "
                 f"{threads}; {datetime.date.today()}, commit {stamp.commit()}", fontsize=9)
    fig.tight_layout()
    fig.savefig(dst, dpi=60)
    for label in labels:
        rows = sorted(runs[label], key=lambda r: r["fluid"])
        n = [r["fluid"] for r in rows]
        print(f"{label}: total per-step slope {slope(n, [r['total_s'] for r in rows]):.3f} over N = "
              f"{n[0]:.0f} .. {n[-1]:.0f}")
    print("wrote", dst)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
