"""Velocity profiles across the channel against the exact series: profile.csv -> PNG.

usage: /usr/bin/python3 plot_profile.py RUN_DIR/profile.csv OUT.png [title] [--last] [--reference REF.csv]

--last draws only the last time; --reference adds a grid solution of the same flow (bench/channel_reference.py's
re<Re>-ny<N>-profile.csv), for the inlet channel at high Re, whose station is still developing at the end time.
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("out")
    ap.add_argument("title", nargs="?", default="channel profile")
    ap.add_argument("--last", action="store_true", help="only the last time")
    ap.add_argument("--reference", help="a finite-difference station profile (y_over_D,u_over_U)")
    args = ap.parse_args()
    with open(args.src) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], [[float(v) for v in r] for r in rows[1:]]
    y = [r[0] for r in data]
    fig, ax = plt.subplots(figsize=(5.5, 4))
    columns = range(len(header) - 2, len(header), 2) if args.last else range(1, len(header), 2)
    exact = "developed parabola" if args.reference else "exact"
    for n, k in enumerate(columns):
        t = header[k].split("_t")[-1]
        ax.plot([r[k] for r in data], y, "o", ms=3, label=f"MPS, t = {t} D/U")
        ax.plot([r[k + 1] for r in data], y, "k-", lw=0.8, label=exact if n == 0 else None)
    if args.reference:
        with open(args.reference) as f:
            ref = [[float(v) for v in r] for r in list(csv.reader(f))[1:]]
        ny = args.reference.rsplit("-ny", 1)[-1].split("-")[0]
        ax.plot([r[1] for r in ref], [r[0] for r in ref], "r--", lw=1.0,
                label=f"finite differences, D/{ny}, same time")
    ax.set_xlabel("u / U")
    ax.set_ylabel("y / D")
    ax.set_title(args.title, fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
