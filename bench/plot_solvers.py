#!/usr/bin/python3
"""Draw bench_solvers' CSV: time per solve against N (log-log, one line per backend, fitted slope in the
legend) and iterations against N.

    /usr/bin/python3 bench/plot_solvers.py bench/results/solvers.csv bench/results/solvers.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import stamp  # noqa: E402


def read(path):
    with open(path) as f:
        lines = f.read().splitlines()
    header = lines[0][2:] if lines and lines[0].startswith("#") else ""
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    return header, rows


def label_of(row):
    spec = row["backend"]
    for tol in (",tol=", ":tol="):
        if tol in spec:  # the tolerance is the same for all rows; keep labels short
            head, _, rest = spec.partition(tol)
            rest = rest.partition(",")[2]
            spec = head + ("," + rest if rest else "")
    if row["phase"] == "reused":
        spec += " (reused setup)"
    return spec


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else "bench/results/solvers.csv"
    out = sys.argv[2] if len(sys.argv) > 2 else "bench/results/solvers.png"
    header, rows = read(src)
    series = {}
    for r in rows:
        if r["source"] != "tank" or r["status"] != "ok":
            continue
        series.setdefault(label_of(r), []).append(
            (int(r["n"]), float(r["total_s"]), float(r["solve_s"]), int(r["iterations"])))

    fig, (ax_t, ax_i) = plt.subplots(1, 2, figsize=(12.5, 5.2), gridspec_kw={"width_ratios": [1.6, 1]})
    markers = "osD^v<>ph*"
    colors = plt.get_cmap("tab10").colors
    for k, (label, pts) in enumerate(sorted(series.items())):
        pts.sort()
        n = np.array([p[0] for p in pts], float)
        t = np.array([p[1] for p in pts])
        it = np.array([p[3] for p in pts])
        baseline = label.startswith("eigen-cg:precond=ic") and "reused" not in label
        style = dict(marker=markers[k % len(markers)], lw=2.6 if baseline else 1.4,
                     ls="--" if "reused" in label else "-", color="black" if baseline else colors[k % 10])
        slope = ""
        if len(n) >= 2:
            slope = f"  (slope {np.polyfit(np.log(n), np.log(t), 1)[0]:.2f})"
        ax_t.loglog(n, t, label=label + slope, **style)
        if "cholmod" not in label:
            ax_i.semilogx(n, it, label=label, **style)
    ax_t.set_xlabel("unknowns N")
    ax_t.set_ylabel("setup + solve per system [s]")
    ax_t.grid(True, which="both", alpha=0.3)
    ax_t.legend(fontsize=7.5, loc="upper left")
    ax_i.set_xlabel("unknowns N")
    ax_i.set_ylabel("iterations to rel. residual tol (x0 = 0)")
    ax_i.set_yscale("log")
    ax_i.set_title("same colours as on the left; cholmod omitted", fontsize=8)
    ax_i.grid(True, which="both", alpha=0.3)
    parts = [p.strip() for p in header.split(";")]
    title = "SparseMPS solvers on the 2-D MPS PPE (water tank, jittered lattice, re = 4.1 l0)"
    if parts and parts[0]:
        date = parts[0].replace("SparseMPS bench_solvers ", "")
        machine = parts[1] if len(parts) > 1 else ""
        extra = [q for q in parts[3:] if q.startswith("tol") or q.startswith("load")]
        title += "\n" + date + ", " + machine + ", commit " + stamp.commit() + \
            ("\n" + "; ".join(extra) if extra else "")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print("wrote", out)


if __name__ == "__main__":
    main()
