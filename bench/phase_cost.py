#!/usr/bin/python3
"""What each phase of a time step costs per particle, against N, with one and two OpenMP threads: the body-force
channel of bench_scaling with the default solver (auto) and the classic path (IC-CG from a zero guess), one process
per size and thread count so that each peak RSS is that run's own. Run it on an idle machine: OpenMP threads spin
at barriers, and a second job on the other core makes two threads many times slower than one.

  bench/phase_cost.py BUILD_DIR [--results bench/results] [--sizes 1e4,1e5,1e6] [--classic-up-to 1e5] [--plot-only]
  bench/phase_cost.py BUILD_DIR --dim 3 [--sizes 1e4,1e5] ...

Writes phase_cost.csv (bench_scaling's columns plus ns per particle per phase) and phase_cost.png. With --dim 3 the
scene is the 3-D dam break (SPHERIC Test 2, its spacing chosen for the fluid count) over its first 8 steps, whole
runs timed by the app's own phase clocks (the first steps included), peak RSS per process: phase_cost3d.csv, .png.
"""
import argparse
import csv
import json
import os
import subprocess
import tempfile
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

PHASES = ["neighbors_s", "predict_s", "assemble_s", "setup_s", "solve_s", "correct_s"]


def run(build, size, threads, solver, cold):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scaling.csv"
        cmd = [str(Path(build) / "bench" / "bench_scaling"), "--sizes", size, "--solvers", "" if cold else solver,
               "--cold", solver if cold else "", "--warmup", "3", "--steps", "5", "--out", str(out)]
        subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS=str(threads)), check=True, capture_output=True)
        with open(out) as f:
            rows = list(csv.DictReader(f))
    for r in rows:
        r["path"] = "classic (IC-CG, zero guess)" if cold else "default (auto)"
        for ph in PHASES:
            r[ph.replace("_s", "_ns_per_particle")] = 1e9 * float(r[ph]) / float(r["fluid"])
        r["bytes_per_particle"] = 1048576 * float(r["peak_rss_mb"]) / float(r["particles"])
    return rows


# SPHERIC Test 2's column, 1.228 m x 1 m x 0.55 m: the spacing that gives about N fluid particles.
COLUMN_M3 = 1.228 * 1.0 * 0.55
STEPS_3D = 8


def run_dambreak3d(build, size, threads, solver, cold):
    dx = (COLUMN_M3 / float(size)) ** (1 / 3)
    # At rest the step is dt_max, 0.061 dx in seconds (2.48e-3 s at dx 0.0407 m): this many steps and a little more.
    end = (STEPS_3D - 0.5) * 0.061 * dx
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(Path(build) / "apps" / "dambreak" / "dambreak"), "--dim", "3", "--dx", f"{dx:.6g}", "--end-time",
               f"{end:.6g}", "--frames", "0", "--solver", solver, "--out", tmp] + (["--cold-start"] if cold else [])
        # A file, not a pipe, for its errors: nothing reads a pipe while wait4 waits (wait4 gives this run's own RSS).
        with open(Path(tmp) / "stderr.txt", "w+") as err:
            proc = subprocess.Popen(cmd, env=dict(os.environ, OMP_NUM_THREADS=str(threads)),
                                    stdout=subprocess.DEVNULL, stderr=err)
            _, status, usage = os.wait4(proc.pid, 0)
            err.seek(0)
            if not (Path(tmp) / "summary.json").exists():
                raise SystemExit(f"{' '.join(cmd)} wrote no summary (exit {os.waitstatus_to_exitcode(status)}): "
                                 f"{err.read().strip()}")
        summary = json.loads((Path(tmp) / "summary.json").read_text())
    t = summary["timings"]
    steps, fluid, total = summary["steps"], summary["particles"]["fluid"], summary["particles"]["total"]
    r = {"size": size, "dx_m": f"{dx:.6g}", "threads": str(threads), "fluid": fluid, "particles": total,
         "steps": steps, "path": "classic (IC-CG, zero guess)" if cold else "default (auto)",
         "neighbors_s": t["neighbors_s"] / steps, "predict_s": t["predict_s"] / steps,
         "assemble_s": t["assemble_s"] / steps, "setup_s": t["solver_setup_s"] / steps,
         "solve_s": t["solve_s"] / steps, "correct_s": t["correct_s"] / steps, "total_s": t["total_s"] / steps,
         "peak_rss_mb": usage.ru_maxrss / 1024.0}
    r["particle_steps_per_s"] = fluid / r["total_s"]
    for ph in PHASES:
        r[ph.replace("_s", "_ns_per_particle")] = 1e9 * r[ph] / fluid
    r["bytes_per_particle"] = 1048576 * r["peak_rss_mb"] / total
    return [r]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--sizes", default="1e4,1e5,1e6")
    ap.add_argument("--classic-up-to", type=float, default=1e5)
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2,
                    help="2: the body-force channel (bench_scaling); 3: the 3-D dam break")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    name = "phase_cost" if a.dim == 2 else "phase_cost3d"
    measure = run if a.dim == 2 else run_dambreak3d
    if a.plot_only:
        with open(results / f"{name}.csv") as f:
            rows = list(csv.DictReader(f))
    else:
        rows = []
        for size in a.sizes.split(","):
            for threads in (1, 2):
                rows += measure(a.build, size, threads, "auto", False)
                if float(size) <= a.classic_up_to:
                    rows += measure(a.build, size, threads, "eigen-cg", True)
                print(*rows[-2:] if float(size) <= a.classic_up_to else rows[-1:], sep="\n", flush=True)
        with open(results / f"{name}.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    default = [r for r in rows if r["path"] == "default (auto)"]
    for ax, threads in zip(axes[:2], ("1", "2")):
        sel = sorted((r for r in default if r["threads"] == threads), key=lambda r: float(r["fluid"]))
        n = [float(r["fluid"]) for r in sel]
        for ph in PHASES:
            ax.plot(n, [float(r[ph.replace("_s", "_ns_per_particle")]) for r in sel], "o-", label=ph[:-2])
        ax.plot(n, [1e9 * float(r["total_s"]) / float(r["fluid"]) for r in sel], "k^-", label="whole step")
        goal = 300 if a.dim == 2 else 1500
        ax.axhline(goal, color="grey", ls=":", lw=1)
        ax.text(n[0], goal, f" {goal} ns: the goal for the non-solver phases", fontsize=7, va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("fluid particles")
        ax.set_ylabel("ns per particle per step")
        ax.set_title(f"default solver (auto), {threads} OpenMP thread{'s' if threads == '2' else ''}", fontsize=9)
        ax.legend(fontsize=7)
    for path, style in (("default (auto)", "o-"), ("classic (IC-CG, zero guess)", "s--")):
        for threads in ("1", "2"):
            sel = sorted((r for r in rows if r["path"] == path and r["threads"] == threads),
                         key=lambda r: float(r["fluid"]))
            if sel:
                axes[2].plot([float(r["fluid"]) for r in sel], [float(r["particle_steps_per_s"]) for r in sel],
                             style, label=f"{path}, {threads} thread{'s' if threads == '2' else ''}")
    axes[2].axhline(1e6 if a.dim == 2 else 2.5e5, color="grey", ls=":", lw=1)
    axes[2].set_xscale("log")
    axes[2].set_yscale("log")
    axes[2].set_xlabel("fluid particles")
    axes[2].set_ylabel("particle-steps per second")
    axes[2].legend(fontsize=7)
    scene = ("Body-force channel (bench_scaling, 5 steps after 3)" if a.dim == 2 else
             f"3-D dam break, SPHERIC Test 2 (its first {STEPS_3D} steps, per fluid particle)")
    fig.suptitle(f"{scene}: cost per phase and throughput", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / f"{name}.png", dpi=120)


if __name__ == "__main__":
    main()
