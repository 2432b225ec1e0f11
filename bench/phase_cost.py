#!/usr/bin/python3
"""What each phase of a time step costs per particle, against N, with one and two OpenMP threads: the body-force
channel of bench_scaling with the default solver (auto) and the classic path (IC-CG from a zero guess), one process
per size and thread count so that each peak RSS is that run's own. Run it on an idle machine: OpenMP threads spin
at barriers, and a second job on the other core makes two threads many times slower than one.

  bench/phase_cost.py BUILD_DIR [--results bench/results] [--sizes 1e4,1e5,1e6] [--classic-up-to 1e5] [--plot-only]
  bench/phase_cost.py BUILD_DIR --dim 3 [--sizes 1e4,1e5] ...
  bench/phase_cost.py BUILD_DIR --against OLD_BUILD [--against-label REV] [--repeat 3] ...   # both builds in turn

Writes phase_cost.csv (bench_scaling's columns plus ns per particle per phase) and phase_cost.png. With --dim 3 the
scene is the 3-D dam break (SPHERIC Test 2, its spacing chosen for the fluid count) over its first 8 steps, whole
runs timed by the app's own phase clocks (the first steps included), peak RSS per process: phase_cost3d.csv, .png.
With --against every run is made with the old build too, the two alternating (the old first at every other size
and repeat), so that a drift of the machine falls on both; the CSV's build column tells them apart, and the table
printed at the end gives each row with the old build's step and non-solver phases against it (old / new). With
--repeat N each case runs N times, and the table and chart show the run whose step took the median time.
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
NON_SOLVER = ["neighbors_s", "predict_s", "assemble_s", "correct_s"]


def with_totals(r):
    r["nonsolver_ns_per_particle"] = sum(float(r[ph.replace("_s", "_ns_per_particle")]) for ph in NON_SOLVER)
    return r


def run(build, size, threads, solver, cold):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scaling.csv"
        cmd = [str(Path(build) / "bench" / "bench_scaling"), "--sizes", size, "--solvers", "" if cold else solver,
               "--cold", solver if cold else "", "--warmup", "3", "--steps", "5", "--out", str(out)]
        subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS=str(threads)), check=True, capture_output=True)
        with open(out) as f:
            rows = list(csv.DictReader(f))
    for r in rows:
        r["size"] = size
        r["path"] = "classic (IC-CG, zero guess)" if cold else "default (auto)"
        for ph in PHASES:
            r[ph.replace("_s", "_ns_per_particle")] = 1e9 * float(r[ph]) / float(r["fluid"])
        r["bytes_per_particle"] = 1048576 * float(r["peak_rss_mb"]) / float(r["particles"])
    return [with_totals(r) for r in rows]


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
    return [with_totals(r)]


def median_runs(rows):
    """Of repeated runs of one build, size, thread count and path, the run whose step took the median time."""
    runs = {}
    for r in rows:
        runs.setdefault((r.get("build"), r.get("size", r["fluid"]), r["threads"], r["path"]), []).append(r)
    return [sorted(same, key=lambda r: float(r["total_s"]))[(len(same) - 1) // 2] for same in runs.values()]


def markdown_table(rows, old_label):
    """The docs' table: one line per run of the new build, with the old build's step and non-solver phases beside."""
    def key(r):
        return (r.get("size"), r["threads"], r["path"])
    old = {key(r): r for r in rows if old_label and r.get("build") == old_label}
    print("| fluid | threads | path | s/step | particle-steps/s | neighbours | assembly | predictor | corrector | "
          "setup | solve | non-solver | PPE, SpMV-eq | peak RSS, per particle | old s/step (old/new) | "
          "old non-solver (old/new) |")
    print("|" + " ---: | ---: | --- |" + " ---: |" * 13)
    for r in rows:
        if r.get("build", "new") != "new":
            continue
        f = {k: float(r[k]) for k in r if k.endswith(("_s", "_ns_per_particle", "_per_s", "_mb", "per_particle"))}
        o = old.get(key(r))
        versus = (f"{float(o['total_s']):.4g} ({float(o['total_s']) / f['total_s']:.2f}) | "
                  f"{float(o['nonsolver_ns_per_particle']):.0f} "
                  f"({float(o['nonsolver_ns_per_particle']) / f['nonsolver_ns_per_particle']:.2f})") if o else "| "
        path = "auto" if r["path"].startswith("default") else "classic"
        spmv = f"{float(r['ppe_spmv_equivalents']):.0f}" if r.get("ppe_spmv_equivalents") else "–"
        print(f"| {int(float(r['fluid'])):,} | {r['threads']} | {path}"
              f" | {f['total_s']:.4g} | {f['particle_steps_per_s']:.3g} | {f['neighbors_ns_per_particle']:.0f} | "
              f"{f['assemble_ns_per_particle']:.0f} | {f['predict_ns_per_particle']:.0f} | "
              f"{f['correct_ns_per_particle']:.0f} | {f['setup_ns_per_particle']:.0f} | "
              f"{f['solve_ns_per_particle']:.0f} | {f['nonsolver_ns_per_particle']:.0f} | "
              f"{spmv} | {f['peak_rss_mb']:.0f} MB, {f['bytes_per_particle']:.0f} B | {versus} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--sizes", default="1e4,1e5,1e6")
    ap.add_argument("--classic-up-to", type=float, default=1e5)
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2,
                    help="2: the body-force channel (bench_scaling); 3: the 3-D dam break")
    ap.add_argument("--against", metavar="OLD_BUILD", help="a build of the previous main, run in turn with this one")
    ap.add_argument("--against-label", default="old", help="the old build's name in the CSV and chart (its commit)")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each case (and build); the median run is shown")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    name = "phase_cost" if a.dim == 2 else "phase_cost3d"
    measure = run if a.dim == 2 else run_dambreak3d
    if a.plot_only:
        with open(results / f"{name}.csv") as f:
            rows = [with_totals(r) for r in csv.DictReader(f)]
    else:
        rows = []
        builds = [(a.build, "new")] + ([(a.against, a.against_label)] if a.against else [])
        for i, size in enumerate(a.sizes.split(",")):
            for threads in (1, 2):
                paths = [("auto", False)] + ([("eigen-cg", True)] if float(size) <= a.classic_up_to else [])
                for solver, cold in paths:
                    for repeat in range(a.repeat):
                        for build, label in builds if (i + repeat) % 2 == 0 else builds[::-1]:
                            run_rows = measure(build, size, threads, solver, cold)
                            for r in run_rows:
                                r["build"], r["repeat"] = label, repeat
                            print(*run_rows, sep="\n", flush=True)
                            rows += run_rows
        with open(results / f"{name}.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    old_label = next((r["build"] for r in rows if r.get("build", "new") != "new"), None)
    rows = median_runs(rows)
    markdown_table(rows, old_label)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    old_rows = [r for r in rows if old_label and r.get("build") == old_label]
    rows = [r for r in rows if r.get("build", "new") == "new"]
    default = [r for r in rows if r["path"] == "default (auto)"]
    for ax, threads in zip(axes[:2], ("1", "2")):
        sel = sorted((r for r in default if r["threads"] == threads), key=lambda r: float(r["fluid"]))
        n = [float(r["fluid"]) for r in sel]
        for ph in PHASES:
            ax.plot(n, [float(r[ph.replace("_s", "_ns_per_particle")]) for r in sel], "o-", label=ph[:-2])
        ax.plot(n, [1e9 * float(r["total_s"]) / float(r["fluid"]) for r in sel], "k^-", label="whole step")
        ax.plot(n, [float(r["nonsolver_ns_per_particle"]) for r in sel], "kx--", label="non-solver phases")
        old = sorted((r for r in old_rows if r["threads"] == threads and r["path"] == "default (auto)"),
                     key=lambda r: float(r["fluid"]))
        if old:
            ax.plot([float(r["fluid"]) for r in old], [1e9 * float(r["total_s"]) / float(r["fluid"]) for r in old],
                    "^:", color="grey", label=f"whole step, {old_label}")
            ax.plot([float(r["fluid"]) for r in old], [float(r["nonsolver_ns_per_particle"]) for r in old],
                    "x:", color="grey", label=f"non-solver, {old_label}")
        goal = 400 if a.dim == 2 else 1500
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
            for which, label, alpha in ((rows, "", 1.0), (old_rows, f", {old_label}", 0.4)):
                sel = sorted((r for r in which if r["path"] == path and r["threads"] == threads),
                             key=lambda r: float(r["fluid"]))
                if sel:
                    axes[2].plot([float(r["fluid"]) for r in sel], [float(r["particle_steps_per_s"]) for r in sel],
                                 style, alpha=alpha,
                                 label=f"{path}, {threads} thread{'s' if threads == '2' else ''}{label}")
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
