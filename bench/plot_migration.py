#!/usr/bin/python3
"""The dam break's step time against the step on 1 and 2 ranks with `auto`, migrating every step and every k-th
(bench_distributed_step --trace, concatenated by `make bench-migration`; docs/scaling.md). A marker where a solve set
an AMG hierarchy up.

  /usr/bin/python3 bench/plot_migration.py TRACE.csv FIGURE.png [DIMENSIONS]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402


def plot_step_times(runs, title, figure):
    """runs: (label, line style, trace rows of one run); the step time against the step, a ring where a solve set an
    AMG hierarchy up."""
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for label, style, rows in runs:
        steps = [int(r["step"]) for r in rows]
        seconds = [float(r["step_s"]) for r in rows]
        line, = ax.plot(steps, seconds, marker=".", ls=style, label=label)
        built = [(s, t) for s, t, r in zip(steps, seconds, rows) if r["hierarchy_built"] == "1"]
        if built:
            ax.plot(*zip(*built), "o", mfc="none", ms=9, color=line.get_color())
    ax.plot([], [], "o", mfc="none", ms=9, color="grey", label="an AMG hierarchy set up")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("step")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("wall time of the step [s] (slowest rank)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(figure, dpi=120)


def main(trace, figure, dimensions):
    runs = {}
    with open(trace, newline="") as f:
        for row in csv.DictReader(f):
            runs.setdefault((int(row["ranks"]), int(row["migrate_every"])), []).append(row)
    if not runs:
        sys.exit(f"{trace}: no rows")
    labelled = []
    for (ranks, every), rows in sorted(runs.items()):
        label = f"{ranks} rank" + ("s" if ranks > 1 else "")
        if ranks > 1:
            label += ", migrating every step" if every == 1 else f", migrating every {every}th step"
        labelled.append((label, "-", rows))
    fluid = float(next(iter(runs.values()))[0]["fluid_target"])
    dim = "3-D (SPHERIC Test 2)" if dimensions == "3" else "2-D"
    plot_step_times(labelled, f"{dim} dam break, about {fluid:.1e} fluid particles, solver auto, one thread per rank",
                    figure)

if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) == 4 else "2")
