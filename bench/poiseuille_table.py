"""Seed 004's Poiseuille table, reproduced: the pushing-plate inlet channel (15 D, station at 10 D) at
Re = 4, 40, 400 with dx = 0.004 m and Re = 400 with dx = 0.0055 / 0.004 / 0.0025 m, to the paper's end time
U t / D = 10 (IC-CG unless the case names another solver); then the particle-steps per second of each solver over
a short stretch of each case.
Writes CSV and Markdown (with date and machine) and keeps every run's outputs under --runs.

usage: /usr/bin/python3 bench/poiseuille_table.py --app build/release/apps/poiseuille/poiseuille [--reuse]
           [--cases re40-dx0.004,re400-dx0.004] [--end-time 10] [--speed-time 0.5]
           [--solvers eigen-cg,hypre-pcg] [--outlet-buffer 5] [--compression 1e-4]
           [--reference runs/channel-reference] [--out bench/results/poiseuille_table]

With --reference, the station profile of each case is also compared with the finest finite-difference solution of
the same flow found there (bench/channel_reference.py, files re<Re>-ny<N>-profile.csv): at Re = 400 the flow at the
station is still developing at U t/D = 10, and the peak error against the developed parabola is mostly that.
"""
import argparse
import datetime
import glob
import json
import os
import platform
import subprocess
import sys

import numpy

import stamp

D = 0.2
# (name, Re, particles across, the paper's peak-velocity error in %, viscosity, dt factor, solver of the accuracy
# run or None for the first of --solvers, particle shifting coefficient). Re = 4 takes implicit viscosity: its explicit limit would need ~31,000
# steps for 10 D/U at dx = 0.004 m, against ~3,750 for CFL. It and the 80-across case (~110,000 particles, ~5,300
# steps) take hypre-pcg, which ran 1.14x and 1.05x the particle-steps of IC-CG in their timing runs (2026-11-24).
CASES = [
    ("re4-dx0.004", 4, 50, 2.6, "implicit", 1.0, "hypre-pcg:reuse=10,tol=1e-6", 1.0),
    ("re40-dx0.004", 40, 50, 2.1, "explicit", 1.0, None, 0.0),
    ("re400-dx0.0055", 400, 36, 12.7, "explicit", 1.0, None, 0.0),  # D / 0.0055 = 36.4: 36 across, dx = 0.00556
    ("re400-dx0.004", 400, 50, 4.0, "explicit", 1.0, None, 0.0),
    ("re400-dx0.0025", 400, 80, 5.9, "explicit", 1.0, "hypre-pcg:reuse=10,tol=1e-6", 0.0),
]


def run(app, out, re, across, viscosity, dt_factor, end_time, solver, threads, reuse, outlet_buffer, compression,
        shifting):
    if reuse:
        try:
            with open(os.path.join(out, "summary.json")) as f:
                summary = json.load(f)
            p = summary["parameters"]
            if (p["re"], p["across"], p.get("viscosity", "explicit"), p["dt_factor"], p["end_time_D_over_U"],
                    p["solver"].split(":")[0], p.get("outlet_buffer_l0", 0.0), p.get("compression", 0.0),
                    p.get("shifting", 0.0)) == (re, across, viscosity, dt_factor, end_time, solver.split(":")[0],
                                                outlet_buffer, compression, shifting):
                print(f"reusing {out}", flush=True)
                return summary
        except (OSError, KeyError, ValueError):
            pass
    cmd = [app, "--mode", "inlet", "--re", str(re), "--across", str(across), "--end-time", str(end_time),
           "--dt-factor", str(dt_factor), "--solver", solver, "--outlet-buffer", str(outlet_buffer),
           "--compression", str(compression), "--shifting", str(shifting), "--frames", "0", "--profiles", "10", "--out", out]
    if viscosity == "implicit":
        cmd.append("--implicit-viscosity")
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    print("$", " ".join(cmd), flush=True)
    done = subprocess.run(cmd, env=env)
    # 0 / 2: ran to the end (2: missed --tolerance); 1: stopped by the guard (summary.json says "failed")
    try:
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
    except OSError:
        sys.exit(f"{out}: the run wrote no summary.json (status {done.returncode}): bad input?")
    if done.returncode not in (0, 2) and summary.get("status") != "failed":
        sys.exit(f"{out}: the run failed with status {done.returncode}")
    return summary


def final_profile(run_dir):
    """y/D and u/U of the last profile the app wrote."""
    with open(os.path.join(run_dir, "profile.csv")) as f:
        rows = [line.strip().split(",") for line in f if line.strip()]
    return [float(r[0]) for r in rows[1:]], [float(r[-2]) for r in rows[1:]]


def reference_profile(directory, re):
    """The finest grid's station profile for this Re, or None."""
    best = None
    for path in glob.glob(os.path.join(directory, f"re{re:g}-ny*-profile.csv")):
        ny = int(path.rsplit("-ny", 1)[1].split("-")[0])
        if best is None or ny > best[0]:
            best = (ny, path)
    if best is None:
        return None
    with open(best[1]) as f:
        rows = [line.strip().split(",") for line in f][1:]
    # the no-slip walls close the profile, so that rows nearer a wall than the first cell centre interpolate
    return best[0], [0.0] + [float(r[0]) for r in rows] + [1.0], [0.0] + [float(r[1]) for r in rows] + [0.0]


def against_reference(run_dir, directory, re):
    """(grid cells across, the reference's peak deficit below 1.5 U in %, |peak - reference peak| / reference peak in
    %, max |u - u_ref| / (1.5 U) in %) with the reference read at the particle rows; NaNs without a reference."""
    nan = float("nan")
    ref = reference_profile(directory, re) if directory else None
    if ref is None:
        return nan, nan, nan, nan
    ny, yr, ur = ref
    y, u = final_profile(run_dir)
    at_rows = numpy.interp(y, yr, ur)
    peak_ref = max(at_rows)
    return (ny, 100 * (1.5 - max(ur)) / 1.5, 100 * abs(max(u) - peak_ref) / peak_ref,
            100 * max(abs(a - b) for a, b in zip(u, at_rows)) / 1.5)


def machine():
    return f"{stamp.machine()}, {platform.system()} {platform.release()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--app", required=True)
    ap.add_argument("--cases", default=",".join(c[0] for c in CASES))
    ap.add_argument("--end-time", type=float, default=10.0, help="U t / D of the accuracy runs (paper: 10)")
    ap.add_argument("--speed-time", type=float, default=0.5, help="U t / D of each solver's timing run")
    ap.add_argument("--solvers", default="eigen-cg,hypre-pcg")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--outlet-buffer", type=float, default=5.0, help="the app's --outlet-buffer (l0; 0: free-surface outlet)")
    ap.add_argument("--compression", type=float, default=1e-4, help="the app's --compression (0: incompressible)")
    ap.add_argument("--reference", default="runs/channel-reference",
                    help="directory of bench/channel_reference.py's profiles ('' for none)")
    ap.add_argument("--runs", default="runs/poiseuille-table")
    ap.add_argument("--out", default="bench/results/poiseuille_table")
    ap.add_argument("--reuse", action="store_true",
                    help="take a run's summary.json from --runs when it has the same case, end time and solver "
                         "(cases run in parallel by separate calls, then tabulated together)")
    args = ap.parse_args()
    wanted = args.cases.split(",")
    unknown = [w for w in wanted if w not in [c[0] for c in CASES]]
    if unknown:
        sys.exit(f"unknown case(s) {unknown}; choose from {[c[0] for c in CASES]}")
    solvers = args.solvers.split(",")
    rows = []
    for name, re, across, paper, viscosity, dt_factor, case_solver, shifting in CASES:
        if name not in wanted:
            continue
        acc = run(args.app, os.path.join(args.runs, name), re, across, viscosity, dt_factor, args.end_time,
                  case_solver or solvers[0], args.threads, args.reuse, args.outlet_buffer, args.compression, shifting)
        stopped = acc.get("status") == "failed"
        nan = float("nan")
        row = {"case": name, "Re": re, "dx_m": D / across, "particles_across": across,
               "end_time_D_over_U": acc["time_s"] * acc["parameters"]["velocity_scale_m_per_s"] / D, "steps": acc["steps"],
               "outcome": "guard stop" if stopped else "ran to the end",
               "peak_velocity_error_pct": nan if stopped else 100 * acc["peak_velocity_error"],
               "paper_peak_velocity_error_pct": paper,
               "profile_l2_error_pct": nan if stopped else 100 * acc["profile_l2_error"],
               "flow_rate_error_pct": nan if stopped else 100 * acc["flow_rate_error"],
               "viscosity": viscosity, "dt_factor": dt_factor, "solver": acc["parameters"]["solver"].split(":")[0],
               "outlet_buffer_l0": args.outlet_buffer, "compression": args.compression, "shifting": shifting}
        ref = (nan,) * 4 if stopped else against_reference(os.path.join(args.runs, name), args.reference, re)
        row.update({"reference_cells_across": ref[0], "reference_peak_below_parabola_pct": ref[1],
                    "peak_error_vs_reference_pct": ref[2], "max_deviation_from_reference_pct": ref[3]})
        for solver in solvers:
            speed = run(args.app, os.path.join(args.runs, f"{name}-speed-{solver}"), re, across, viscosity,
                        dt_factor, args.speed_time, solver, args.threads, args.reuse, args.outlet_buffer,
                        args.compression, shifting)
            row[f"{solver}_particle_steps_per_s"] = speed.get("particle_steps_per_s", float("nan"))
        rows.append(row)
        write(rows, args, solvers)  # after every case: a long table keeps what it has if stopped


def write(rows, args, solvers):
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    keys = list(rows[0].keys())
    with open(args.out + ".csv", "w") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(",".join(f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + "\n")
    today = datetime.date.today().isoformat()
    with open(args.out + ".md", "w") as f:
        f.write(f"Measured {today} on {machine()}, {args.threads} OpenMP thread(s) per run, other runs sharing the cores. Inlet channel 15 D, station at "
                f"x = 10 D, profile averaged over the last 1 D/U; outlet buffer {args.outlet_buffer:g} l0, compression "
                f"{args.compression:g}; accuracy run with the solver named (`{solvers[0]}` unless the case names another), "
                f"speeds over {args.speed_time:g} D/U of each case. Reference: the same flow by finite differences "
                f"(bench/channel_reference.py) on the grid named, its station peak below 1.5 U, and our peak against "
                f"its peak and our profile's largest deviation from it (in 1.5 U), read at the particle rows.\n\n")
        f.write("| case | Re | dx [m] | U t/D reached | outcome | peak error (ours) | peak error (paper) | profile L2 | flow rate | "
                + " | ".join(f"{s} particle-steps/s" for s in solvers) + " | viscosity | shifting | Δt factor | accuracy solver | "
                "reference grid | reference peak below 1.5 U | peak vs reference | max deviation from reference |\n")
        f.write("|---|---:|---:|---:|---|---:|---:|---:|---:|" + "---:|" * len(solvers) + "---|---:|---:|---|---:|---:|---:|---:|\n")
        for r in rows:
            f.write(f"| {r['case']} | {r['Re']} | {r['dx_m']:.5f} | {r['end_time_D_over_U']:.2f} | {r['outcome']} | "
                    f"{r['peak_velocity_error_pct']:.2f} % | {r['paper_peak_velocity_error_pct']} % | "
                    f"{r['profile_l2_error_pct']:.2f} % | {r['flow_rate_error_pct']:.2f} % | "
                    + " | ".join(f"{r[s + '_particle_steps_per_s']:.3g}" for s in solvers)
                    + f" | {r['viscosity']} | {r['shifting']:g} | {r['dt_factor']} | {r['solver']} | "
                    f"D/{r['reference_cells_across']:g} | {r['reference_peak_below_parabola_pct']:.2f} % | "
                    f"{r['peak_error_vs_reference_pct']:.2f} % | {r['max_deviation_from_reference_pct']:.2f} % |\n")
    print(f"wrote {args.out}.csv and {args.out}.md", flush=True)


if __name__ == "__main__":
    main()
