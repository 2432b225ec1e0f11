#!/usr/bin/python3
"""The distributed dam break's load imbalance against time, one line per rebalance threshold, from the per-step
traces of bench_distributed_step --trace (concatenated into one CSV; docs/scaling.md "Keeping the cuts").

  scripts/plot_rebalance.py bench/results/rebalance_trace.csv bench/results/rebalance_trace.png
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("trace")
    parser.add_argument("out")
    args = parser.parse_args()
    runs = {}
    with open(args.trace) as f:
        for row in csv.DictReader(f):
            runs.setdefault(row["rebalance_threshold"], []).append(row)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for threshold, rows in sorted(runs.items(), key=lambda kv: -float(kv[0])):
        time = [float(r["time_s"]) for r in rows]
        imbalance = [float(r["imbalance"]) for r in rows]
        renewed = sum(int(r["repartitioned"]) for r in rows)
        label = "cuts kept (no rebalancing)" if threshold == "inf" else f"threshold {threshold}"
        ax.plot(time, imbalance, lw=1.2, label=f"{label}: {renewed} repartitions")
        if threshold == "inf":
            ax.plot(time, [float(r["fluid_imbalance"]) for r in rows], lw=0.8, ls="--", color="grey",
                    label="cuts kept, fluid particles alone")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("largest rank's particles / mean")
    ax.set_title("Classic dam break on 2 ranks (1,850 particles, 800 fluid)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)


if __name__ == "__main__":
    main()
