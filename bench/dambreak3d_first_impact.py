#!/usr/bin/python3
"""SPHERIC Test 2's first impact against the spacing (docs/dambreak3d.md): P1's arrival and first peak, as the app
reads them every step, for each setting at each spacing, against the record (Kleefsman et al. 2005) and the issue's
targets (arrival within 3 %, first peak within 15 %). Writes bench/results/NAME.csv and NAME.png.

  bench/dambreak3d_first_impact.py BUILD_DIR [--spacings 0.05,0.04,0.03,0.02] [--ranks-at 0.02=2]
      [--settings "default=;corrected+wet=--gradient corrected-min-reference --wet-walls"] [--end-time 0.7] [--jobs 1]
      [--runs runs/dambreak3d_first_impact] [--name dambreak3d_first_impact]

One OpenMP thread per run or per rank; the runs on ranks go one at a time after the others. A run whose summary is in
--runs is read, not rerun. At 0.02 m (248,480 particles) a run to 0.7 s takes about half an hour on 2 ranks.
"""
import argparse
import csv
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from dambreak3d_study import ROOT, run

DEFAULT_SETTINGS = "default=;corrected+wet=--gradient corrected-min-reference --wet-walls"
TARGETS = {"p1_arrival_error": 0.03, "p1_first_peak_error": 0.15}


def signed_error(checks, key, record_key):
    value = checks.get(key)
    return None if value is None else value / checks[record_key] - 1.0


def plot(rows, chart, command):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    panels = [("arrival", "P1 arrival against the record [%]", TARGETS["p1_arrival_error"]),
              ("first_peak", "P1 first peak against the record [%]", TARGETS["p1_first_peak_error"])]
    for (key, label, target), ax in zip(panels, axes):
        ax.axhspan(-100 * target, 100 * target, color="0.9", label=f"target (within {100 * target:.0f} %)")
        ax.axhline(0, color="k", lw=0.6)
        for setting in dict.fromkeys(r["setting"] for r in rows):
            mine = [r for r in rows if r["setting"] == setting and r[key + "_error"] is not None]
            ax.plot([r["dx_m"] for r in mine], [100 * r[key + "_error"] for r in mine], "o-", label=setting)
        ax.set_xscale("log")
        ax.invert_xaxis()
        spacings = sorted({r["dx_m"] for r in rows})
        ax.set_xticks(spacings, [f"{dx:g}" for dx in spacings])
        ax.minorticks_off()
        ax.set_xlabel("spacing [m]")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    fig.suptitle(command, fontsize=8)
    fig.tight_layout()
    fig.savefig(chart, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("--spacings", default="0.05,0.04,0.03,0.02")
    parser.add_argument("--ranks-at", default="0.02=2", help="spacing=ranks,...: the spacings run on MPI ranks")
    parser.add_argument("--settings", default=DEFAULT_SETTINGS, help="name=app options;...")
    parser.add_argument("--end-time", type=float, default=0.7)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--runs", default="runs/dambreak3d_first_impact")
    parser.add_argument("--name", default="dambreak3d_first_impact")
    a = parser.parse_args()
    exe = Path(a.build) / "apps" / "dambreak" / "dambreak"
    spacings = [float(s) for s in a.spacings.split(",")]
    ranks_at = {float(k): int(v) for k, v in (item.split("=") for item in a.ranks_at.split(",") if item)}
    settings = [item.split("=", 1) for item in a.settings.split(";")]
    cases = [(name, options.split(), dx) for name, options in settings for dx in spacings]

    def one(case):
        name, options, dx = case
        return run(exe, Path(a.runs) / f"{name}_dx{dx}", dx, a.end_time, options, ranks_at.get(dx, 1))

    serial = sorted((c for c in cases if ranks_at.get(c[2], 1) == 1), key=lambda c: c[2])  # the longest first
    with ThreadPoolExecutor(a.jobs) as pool:
        summaries = {(c[0], c[2]): s for c, s in zip(serial, pool.map(one, serial))}
    for c in cases:
        if (c[0], c[2]) not in summaries:
            summaries[(c[0], c[2])] = one(c)
    rows = []
    for name, options, dx in cases:
        s = summaries[(name, dx)]
        checks = s.get("checks", {})
        rows.append({"setting": name, "options": " ".join(options), "dx_m": dx,
                     "ranks": s["parameters"].get("ranks", 1), "particles": s["particles"]["total"],
                     "fluid": s["particles"]["fluid"], "steps": s["steps"], "time_s": s["time_s"],
                     "p1_arrival_s": checks.get("p1_arrival_s"),
                     "arrival_error": signed_error(checks, "p1_arrival_s", "p1_arrival_record_s"),
                     "p1_first_peak_pa": checks.get("p1_first_peak_pa"),
                     "first_peak_error": signed_error(checks, "p1_first_peak_pa", "p1_first_peak_record_pa"),
                     "p1_noise_rms_pa": checks.get("p1_noise_rms_pa"),
                     "wall_s": s.get("timings", {}).get("total_s")})
        print({k: rows[-1][k] for k in ("setting", "dx_m", "p1_arrival_s", "arrival_error", "p1_first_peak_pa",
                                        "first_peak_error")}, flush=True)
    results = ROOT / "bench" / "results"
    with (results / f"{a.name}.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, results / f"{a.name}.png",
         f"bench/dambreak3d_first_impact.py BUILD_DIR --spacings {a.spacings} --ranks-at {a.ranks_at} "
         f"--end-time {a.end_time:g}")
    print("wrote", results / f"{a.name}.csv", "and", results / f"{a.name}.png")


if __name__ == "__main__":
    main()
