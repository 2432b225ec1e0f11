#!/usr/bin/python3
"""Run-to-run robustness of the seed column's wall pressure (docs/dambreak.md, issue 38): the default run beside the
same run with another solver or shifting coefficient, at each spacing, against Buchner at 0.2 H. Writes
bench/results/dambreak_robustness.csv (arrival, first peak, noise, plateau, second impact at 0.2 H; the backstop's
returns) and a chart of each variant's 0.2 H signal against the experiment.

  bench/dambreak_robustness.py BUILD_DIR [--spacings 25,50,100] [--runs DIR] [--jobs 2]

One thread per run, two runs at a time: an H/50 run took about 2.5 min here and an H/100 run 20-36 min beside other
runs. A run whose summary is already in --runs is read, not rerun (delete it to rerun).
"""
import json
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor

from dambreak_pressure import FIGURES, KEYS, plot_against_buchner, seed_bench_setup, write_rows

# label, folder, the options beside --column seed --dx; the shifting variants at H/50 only
VARIANTS = [("auto (default)", "auto", []), ("IC-CG", "eigen-cg", ["--solver", "eigen-cg"]),
            ("Jacobi-CG", "eigen-cg_precond_jacobi", ["--solver", "eigen-cg:precond=jacobi"]),
            ("shifting 0.25", "v_shift025", ["--shifting", "0.25"]), ("shifting 1", "v_shift1", ["--shifting", "1"])]
SHIFTING_AT = 50


def variants_at(across):
    return [v for v in VARIANTS if across == SHIFTING_AT or not v[1].startswith("v_")]


def folder(runs, name, across):
    return runs / (f"{name}_{1.0 / across!r}" if not name.startswith("v_") else name)


def run(exe, out, options, across):
    summary = out / "summary.json"
    if not summary.exists():
        out.mkdir(parents=True, exist_ok=True)
        subprocess.run([str(exe), "--column", "seed", "--dx", repr(1.0 / across), *options, "--out", str(out)],
                       capture_output=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    return json.loads(summary.read_text())


def plot(runs, chart, spacings):
    plot_against_buchner(chart, spacings, lambda across: [
        (label, folder(runs, name, across) / "pressure.csv") for label, name, _ in variants_at(across)], top=1.3)


def main():
    args, results, runs, exe, spacings = seed_bench_setup("runs/dambreak_robustness", "25,50,100")
    jobs = [(across, v) for across in spacings for v in variants_at(across)]
    with ThreadPoolExecutor(args.jobs) as pool:
        summaries = list(pool.map(lambda j: run(exe, folder(runs, j[1][1], j[0]), j[1][2], j[0]), jobs))
    rows = []
    for (across, (label, _, _)), s in zip(jobs, summaries):
        checks = s["checks"]
        row = {"variant": label, "spacing": f"H/{across}", "status": s["status"],
               "tank_length_m": s["parameters"]["tank_length_m"],
               "fluid_returned_to_a_face": checks["fluid_returned_to_a_face_count"],
               "most_fluid_inside_walls": checks["most_fluid_inside_walls_count"]}
        for name in FIGURES:
            row[name] = checks["impact"][KEYS[name]]
        rows.append(row)
        print(" ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row.values()))
    write_rows(results / "dambreak_robustness.csv", rows)
    plot(runs, results / "dambreak_robustness.png", spacings)


if __name__ == "__main__":
    main()
