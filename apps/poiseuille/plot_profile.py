"""Velocity profiles across the channel against the exact series: profile.csv -> PNG.

usage: /usr/bin/python3 plot_profile.py RUN_DIR/profile.csv OUT.png [title]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main():
    src, out = sys.argv[1], sys.argv[2]
    title = sys.argv[3] if len(sys.argv) > 3 else "channel profile"
    with open(src) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], [[float(v) for v in r] for r in rows[1:]]
    y = [r[0] for r in data]
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for k in range(1, len(header), 2):
        t = header[k].split("_t")[-1]
        ax.plot([r[k] for r in data], y, "o", ms=3, label=f"MPS, t = {t} D/U")
        ax.plot([r[k + 1] for r in data], y, "k-", lw=0.8, label="exact" if k == 1 else None)
    ax.set_xlabel("u / U")
    ax.set_ylabel("y / D")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
