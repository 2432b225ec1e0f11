#!/usr/bin/python3
"""What the pressure gradient and particle shifting (along the free surface) do to the dam break: the classic column's
surge front against Martin & Moyce and Koshizuka & Oka (a/20 and a/40, to T = 2.5) and the seed column's impact at
0.2 H against Buchner (H/25 and the seed's H/50), for each setting. CSV (bench/results/dambreak_variants.csv).

  bench/dambreak_variants.py BUILD_DIR [--results bench/results] [--jobs 2]   (one thread per run; about 8 minutes)
  bench/dambreak_variants.py BUILD_DIR --settings "LABEL;LABEL" --name NAME   (those settings only, to NAME.csv)
"""
import argparse
import csv
import json
import os
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

# label -> extra arguments (the gradient is min-reference unless said).
SETTINGS = {
    "min-reference, no shifting": ["--shifting", "0"],
    "gradient plain": ["--gradient", "plain", "--shifting", "0"],
    "gradient corrected": ["--gradient", "corrected", "--shifting", "0"],
    "gradient corrected-min-reference": ["--gradient", "corrected-min-reference", "--shifting", "0"],
    "gradient corrected-min-reference, shifting 0.5": ["--gradient", "corrected-min-reference", "--shifting", "0.5"],
    "gradient corrected-min-reference, shifting 0.5, wet walls": ["--gradient", "corrected-min-reference",
                                                                  "--shifting", "0.5", "--wet-walls"],
    "shifting 0.5 (the default)": ["--shifting", "0.5"],
    "shifting 1": ["--shifting", "1"],
    "shifting 2": ["--shifting", "2"],
    "shifting 5": ["--shifting", "5"],
    "wet walls": ["--wet-walls", "--shifting", "0"],
    "wet walls, shifting 1": ["--wet-walls", "--shifting", "1"],
    "wet walls, shifting 0.5": ["--wet-walls", "--shifting", "0.5"],
}
# Each spacing given, not left to the app's default (the classic column's became a/40).
RUNS = [("classic", "a/20", ["--dx", str(0.146 / 20)]), ("classic", "a/40", ["--dx", str(0.146 / 40)]),
        ("seed", "H/25", ["--dx", "0.04"]), ("seed", "H/50", ["--dx", "0.02"])]


def run(exe, column, extra):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([str(exe), "--column", column, *extra, "--frames", "0", "--out", out], capture_output=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
        return json.loads((Path(out) / "summary.json").read_text())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--settings", help="labels of SETTINGS separated by ';' (default: all)")
    ap.add_argument("--name", default="dambreak_variants", help="the CSV's name without .csv")
    args = ap.parse_args()
    chosen = args.settings.split(";") if args.settings else list(SETTINGS)
    unknown = [label for label in chosen if label not in SETTINGS]
    if unknown:
        ap.error(f"unknown setting {unknown}; the settings are {list(SETTINGS)}")
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    exe = Path(args.build) / "apps" / "dambreak" / "dambreak"
    jobs = [(label, column, spacing, SETTINGS[label] + more) for label in chosen for column, spacing, more in RUNS]
    with ThreadPoolExecutor(args.jobs) as pool:
        summaries = list(pool.map(lambda j: run(exe, j[1], j[3]), jobs))
    rows = []
    for (label, column, spacing, _), s in zip(jobs, summaries):
        c = s.get("checks", {})
        impact = c.get("impact", {})
        row = {"setting": label, "column": column, "spacing": spacing, "status": s["status"],
               "time_s": s["time_s"], "steps": s["steps"]}
        # The CSV keeps its columns; the summary's keys follow docs/config-files.md.
        for column_name, key in (("front_max_error_martin_moyce_1", "martin_moyce_1_front_max_error"),
                                 ("front_max_error_martin_moyce_2", "martin_moyce_2_front_max_error"),
                                 ("front_max_error_koshizuka_oka", "koshizuka_oka_front_max_error")):
            row[column_name] = c.get(key, "") if column == "classic" else ""
        for column_name, key in (("arrival", "arrival_t_sqrt_g_over_H"), ("first_peak", "first_peak_over_rho_g_H"),
                                 ("noise", "noise_over_range")):
            row[column_name] = impact.get(key, "") if column == "seed" else ""
        row["spray_removed"] = c.get("fluid_removed_as_spray_count", "")
        rows.append(row)
        print(row, flush=True)
    with open(results / f"{args.name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
