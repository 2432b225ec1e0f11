#!/usr/bin/python3
"""SPHERIC Test 2, the 3-D dam break hitting a box (docs/dambreak3d.md): `dambreak --dim 3` at each spacing, its P1
arrival and first peak and its H2 and H4 heights against the experiment (Kleefsman et al. 2005), every other sensor and
gauge reported. Writes bench/results/dambreak3d.csv and dambreak3d.png (P1, H2 and H4 against the record; the other
sensors and gauges beside them), and NAME_sensors.csv: every pressure sensor's arrival, first peak and largest value,
and every height gauge's first wetting (a water height over 2 cm), mean (over time) and largest height, at each
spacing.

  bench/dambreak3d_study.py BUILD_DIR [--spacings 0.05,0.04] [--runs DIR] [--jobs 1] [--end-time 6] [-- extra args]

One thread per run. At 0.04 m (56,000 particles) a run to 6 s takes about half an hour on one core. A run whose summary
is already in --runs is read, not rerun (delete its folder to rerun it).
"""
import argparse
import csv
import json
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ["p1_arrival_s", "p1_arrival_record_s", "p1_arrival_error", "p1_first_peak_pa", "p1_first_peak_record_pa",
           "p1_first_peak_error", "p1_noise_rms_pa", "h2_mean_absolute_error_over_column_height",
           "h4_mean_absolute_error_over_column_height", "fluid_removed_as_spray_count", "most_fluid_inside_walls_count",
           "deepest_past_wall_l0"]


def run(exe, out, dx, end_time, extra, ranks=1):
    """One run (on `ranks` MPI ranks, one thread each) unless `out` holds its summary already."""
    summary = out / "summary.json"
    if not summary.exists():
        out.mkdir(parents=True, exist_ok=True)
        launcher = [] if ranks == 1 else ["mpiexec", "-np", str(ranks)]
        with (out / "console.txt").open("w") as log:
            subprocess.run([*launcher, str(exe), "--dim", "3", "--dx", repr(dx), "--end-time", repr(end_time),
                            "--frames", "0", "--out", str(out), *extra], stdout=log, stderr=subprocess.STDOUT,
                           env=dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
                                    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1"))
    return json.loads(summary.read_text())


def read_csv(path):
    with path.open() as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def plot(runs, spacings, chart, xmax):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    record = read_csv(ROOT / "data" / "dambreak" / "spheric2_p1_h2_h4.csv")
    fig, axes = plt.subplots(3, 2, figsize=(12, 10))
    panels = [("P1_Pa", "P1_Pa", "pressure.csv", "P1 [Pa]"), ("H2_m", "H2_m", "level.csv", "H2 [m]"),
              ("H4_m", "H4_m", "level.csv", "H4 [m]")]
    for (column, record_column, name, label), ax in zip(panels, axes[:, 0]):
        ax.plot(record["time_s"], record[record_column], "k", lw=0.6, label="experiment (Kleefsman et al. 2005)")
        for dx in spacings:
            path = runs / f"dx{dx}" / name
            if path.exists():
                series = read_csv(path)
                ax.plot(series["time_s"], series[column], lw=1.0, label=f"dx = {dx} m")
        ax.set_ylabel(label)
        ax.set_xlim(0, xmax)
        ax.legend(fontsize=7)
    finest = runs / f"dx{spacings[-1]}"
    others = [("pressure.csv", ["P2_Pa", "P3_Pa", "P4_Pa"], "P2-P4 [Pa] (no data here)"),
              ("pressure.csv", ["P5_Pa", "P6_Pa", "P7_Pa", "P8_Pa"], "P5-P8, the box's top [Pa] (no data here)"),
              ("level.csv", ["H1_m", "H3_m"], "H1, H3 [m] (no data here)")]
    for (name, columns, label), ax in zip(others, axes[:, 1]):
        if (finest / name).exists():
            series = read_csv(finest / name)
            for c in columns:
                ax.plot(series["time_s"], series[c], lw=0.8, label=f"{c.split('_')[0]}, dx = {spacings[-1]} m")
        ax.set_ylabel(label)
        ax.set_xlim(0, xmax)
        ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    fig.suptitle("SPHERIC Test 2: bench/dambreak3d_study.py BUILD_DIR --spacings " + ",".join(map(str, spacings)))
    fig.tight_layout()
    fig.savefig(chart, dpi=110)


WET_M = 0.02  # a gauge counts as wet once its water is deeper than this


def gauge_figures(t, h):
    """First wetting, mean height over time (the trapezoid rule: a run's steps are not equal) and largest height."""
    wet = next((tk for tk, v in zip(t, h) if v > WET_M), "")
    area = sum(0.5 * (h[k] + h[k + 1]) * (t[k + 1] - t[k]) for k in range(len(t) - 1))
    return [wet, area / (t[-1] - t[0]), max(h)]


def write_sensors(runs, spacings, summaries, path):
    """Every sensor and gauge at every spacing: the figures to check against the experiment's records not given here.
    The record's rows (dx_m "record": P1 from the run's own reading of it, H2 and H4 over the runs' span) lead."""
    record = read_csv(ROOT / "data" / "dambreak" / "spheric2_p1_h2_h4.csv")
    span = sum(1 for t in record["time_s"] if t <= min(s["time_s"] for s in summaries))
    record = {k: v[:span] for k, v in record.items()}
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["dx_m", "sensor", "arrival_s", "first_peak_pa", "largest_pa", "first_wet_s", "mean_height_m",
                    "largest_height_m"])
        checks = summaries[0].get("checks", {})
        w.writerow(["record", "P1", checks.get("p1_arrival_record_s", ""), checks.get("p1_first_peak_record_pa", ""),
                    max(record["P1_Pa"]), "", "", ""])
        for gauge in ("H2", "H4"):
            w.writerow(["record", gauge, "", "", "", *gauge_figures(record["time_s"], record[f"{gauge}_m"])])
        for dx, s in zip(spacings, summaries):
            checks = s.get("checks", {})
            for p in checks.get("pressure_sensors", []):
                w.writerow([dx, p["name"], p.get("arrival_s", ""), p.get("first_peak_pa", ""), p["largest_pa"], "", "",
                            ""])
            level = read_csv(runs / f"dx{dx}" / "level.csv")
            for g in checks.get("height_gauges", []):
                w.writerow([dx, g["name"], "", "", "", *gauge_figures(level["time_s"], level[f"{g['name']}_m"])])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("--spacings", default="0.05,0.04")
    parser.add_argument("--runs", default="runs/dambreak3d_study")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--end-time", type=float, default=6.0)
    parser.add_argument("--name", default="dambreak3d")
    parser.add_argument("extra", nargs="*")
    a = parser.parse_args()
    exe = Path(a.build) / "apps" / "dambreak" / "dambreak"
    runs = Path(a.runs)
    spacings = [float(s) for s in a.spacings.split(",")]
    with ThreadPoolExecutor(a.jobs) as pool:  # the finest (longest) run first, so that jobs > 1 end together
        done = dict(zip(sorted(spacings), pool.map(lambda dx: run(exe, runs / f"dx{dx}", dx, a.end_time, a.extra),
                                                   sorted(spacings))))
    summaries = [done[dx] for dx in spacings]
    results = ROOT / "bench" / "results"
    with (results / f"{a.name}.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["dx_m", "fluid", "particles", "steps", "time_s", *FIGURES, "wall_s"])
        for dx, s in zip(spacings, summaries):
            checks = s.get("checks", {})
            w.writerow([dx, s["particles"]["fluid"], s["particles"]["total"], s["steps"], s["time_s"],
                        *[checks.get(k, "") for k in FIGURES], s.get("timings", {}).get("total_s", "")])
            print(dx, s["status"], {k: checks.get(k) for k in FIGURES})
    write_sensors(runs, spacings, summaries, results / f"{a.name}_sensors.csv")
    plot(runs, spacings, results / f"{a.name}.png", min(6.0, a.end_time + 0.5))
    print("wrote", results / f"{a.name}.csv", "and", results / f"{a.name}.png")


if __name__ == "__main__":
    main()
