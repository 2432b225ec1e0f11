"""Error against wall time (design section 7): the Pareto front over spacing, solver backend, tolerance, initial
guess and gamma, for two scenes with exact solutions:

  poiseuille  apps/poiseuille --mode body-force (periodic channel, Re 40, to 10 D/U); error = relative L2 error
              ||u - exact|| / ||exact|| of the velocity profile against the transient series (summary.json: profile_l2_error);
  couette     apps/rotating --scene couette (annulus, inner cylinder turning, to t = 1 s); error = max |u_theta -
              exact| over omega R1 (summary.json: checks.max_abs_error_over_omega_R1), a peak error.

usage: OMP_NUM_THREADS=1 /usr/bin/python3 bench/pareto.py BUILD_DIR [--defaults] [--full]
           [--scenes poiseuille,couette] [--runs runs/pareto] [--results bench/results]

Runs the built apps one at a time (BUILD_DIR/apps/...), writes RESULTS/pareto_<scene>.csv and .png, and prints, per
scene, the fastest setting that reached 1 % and 0.1 % error. Wall time is the app's whole run measured around the
process (scene set-up included, no frames written); the phase sum from summary.json is kept as sim_s.

The quick sweep (default): every backend at every spacing of the scene at tol = 1e-8 and the scene's gamma, then
tolerance and gamma one at a time around the app's default solver at the middle spacing. --full adds spacings
(the apps' default spacings among them) and runs the tolerance and gamma variants at every spacing. --defaults
adds the app defaults at the app's own spacing (poiseuille 50, couette 20 across) to a sweep that lacks them.

Marked on the chart: the app defaults (eigen-cg, which is precond=ic at tol=1e-8, warm start, the scene's gamma;
at the app's default spacing when it is in the sweep) and the classic baseline: IC-preconditioned CG from a zero
initial guess (--cold-start), no setup reuse.
"""
import argparse
import csv
import os
import sys
import time

import stamp
from runapp import run_app

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

# Backends at the default tolerance: (name, solver spec, warm start).
BACKENDS = [
    ("IC-CG warm (app default)", "eigen-cg:precond=ic,tol=1e-8", True),
    ("IC-CG cold (baseline)", "eigen-cg:precond=ic,tol=1e-8", False),
    ("Jacobi-CG", "eigen-cg:precond=jacobi,tol=1e-8", True),
    ("hypre-pcg", "hypre-pcg:tol=1e-8", True),
    ("hypre-pcg reuse=10", "hypre-pcg:tol=1e-8,reuse=10", True),
    ("cholmod", "cholmod", True),
]
TOLERANCES = ["1e-4", "1e-6", "1e-10"]  # around the default 1e-8, with IC-CG warm

SCENES = {
    "poiseuille": {
        "app": "apps/poiseuille/poiseuille",
        "args": ["--mode", "body-force", "--frames", "0", "--profiles", "1"],
        "title": "Body-force Poiseuille channel (periodic, Re 40, t = 10 D/U)",
        "error": "profile L2 error vs series [%]",
        "spacings": [10, 20, 30], "middle": 20, "full_spacings": [10, 15, 20, 30, 40, 50], "default_across": 50,
        "gamma": 0.99, "gammas": [0.01, 0.1, 0.5],
    },
    "couette": {
        "app": "apps/rotating/rotating",
        "args": ["--scene", "couette", "--frames", "0"],
        "title": "Taylor-Couette annulus (t = 1 s)",
        "error": "max |u_theta - exact| / (omega R1) [%]",
        "spacings": [8, 10, 13], "middle": 10, "full_spacings": [8, 10, 13, 16, 20], "default_across": 20,
        "gamma": 0.01, "gammas": [0.05, 0.1, 0.5],
    },
}


def error_of(scene, summary):
    if scene == "poiseuille":
        return summary["profile_l2_error"]
    return summary["checks"]["max_abs_error_over_omega_R1"]


def settings(scene, full, defaults):
    s = SCENES[scene]
    spacings = s["full_spacings"] if full else s["spacings"]
    runs = []
    for across in spacings:
        for name, spec, warm in BACKENDS:
            runs.append({"label": name, "group": name, "across": across, "solver": spec, "warm_start": warm,
                         "gamma": s["gamma"]})
    for across in spacings if full else [s["middle"]]:
        for tol in TOLERANCES:
            runs.append({"label": f"IC-CG tol={tol}", "group": "IC-CG tol", "across": across,
                         "solver": f"eigen-cg:precond=ic,tol={tol}", "warm_start": True, "gamma": s["gamma"]})
        for g in s["gammas"]:
            runs.append({"label": f"IC-CG gamma={g}", "group": "IC-CG gamma", "across": across,
                         "solver": "eigen-cg:precond=ic,tol=1e-8", "warm_start": True, "gamma": g})
    if defaults and s["default_across"] not in spacings:
        name, spec, warm = BACKENDS[0]
        runs.append({"label": name, "group": name, "across": s["default_across"], "solver": spec, "warm_start": warm,
                     "gamma": s["gamma"]})
    for r in runs:
        r["scene"] = scene
        r["app_default"] = r["group"] == BACKENDS[0][0] and r["across"] == s["default_across"]
        r["baseline"] = r["group"] == BACKENDS[1][0]
    return runs


def run_one(build, r, runs_dir):
    s = SCENES[r["scene"]]
    tag = f"{r['label']}_{r['across']}".replace(" ", "_").replace("(", "").replace(")", "").replace("=", "")
    out = os.path.join(runs_dir, r["scene"], tag)
    cmd = [os.path.join(build, s["app"]), *s["args"], "--across", str(r["across"]), "--gamma", str(r["gamma"]),
           "--solver", r["solver"], "--out", out]
    if not r["warm_start"]:
        cmd.append("--cold-start")
    print(" ".join(cmd), flush=True)
    proc, summary, r["wall_s"] = run_app(cmd, out)
    # Exit 2 is the app's accuracy check missed: the run finished and its error is a valid point.
    if proc.returncode in (0, 2) and "timings" in summary:
        t = summary["timings"]
        r.update(status="ran", error=error_of(r["scene"], summary), sim_s=t["total_s"], solve_s=t["solve_s"],
                 setup_s=t["solver_setup_s"], steps=summary["steps"], particles=summary["particles"],
                 spec=summary["parameters"]["solver"])
    else:
        why = summary.get("error") or (proc.stderr.strip().splitlines() or ["exit %d" % proc.returncode])[-1]
        r.update(status="failed: " + why[:200].replace(",", ";"), error=float("nan"))
    print("   %-24s %3d across  %s  error %s  wall %.2f s" % (
        r["label"], r["across"], r["status"][:60], "%.4f %%" % (100 * r["error"]) if r["status"] == "ran" else "-",
        r["wall_s"]), flush=True)
    return r


# Errors within this relative margin count as equal: at one spacing every backend at tol <= 1e-4 gives the same error
# to ~1e-6 relative, and a later point that is "better" only in the 7th digit is not a trade-off.
SAME_ERROR = 1e-3


def pareto(rows):
    ok = sorted((r for r in rows if r["status"] == "ran"), key=lambda r: (r["wall_s"], r["error"]))
    front, best = [], float("inf")
    for r in ok:
        if r["error"] < best * (1 - SAME_ERROR):
            front.append(r)
            best = r["error"]
    return front


STYLE = {  # group -> (marker, colour)
    "IC-CG warm (app default)": ("o", "tab:blue"),
    "IC-CG cold (baseline)": ("s", "black"),
    "Jacobi-CG": ("v", "tab:orange"),
    "hypre-pcg": ("^", "tab:green"),
    "hypre-pcg reuse=10": ("D", "tab:olive"),
    "cholmod": ("P", "tab:purple"),
    "IC-CG tol": ("<", "tab:cyan"),
    "IC-CG gamma": (">", "tab:red"),
}


def plot(scene, rows, png, run_stamp):
    s = SCENES[scene]
    fig, ax = plt.subplots(figsize=(8.6, 5.6))
    for group, (marker, colour) in STYLE.items():
        pts = [r for r in rows if r["group"] == group and r["status"] == "ran"]
        if not pts:
            continue
        ax.scatter([r["wall_s"] for r in pts], [100 * r["error"] for r in pts], marker=marker,
                   facecolors="none" if group == "IC-CG cold (baseline)" else colour, edgecolors=colour, s=36,
                   label=group + ("" if group.startswith("IC-CG ") and group.split()[-1] in ("tol", "gamma")
                                  else ", tol 1e-8"), zorder=3)
        for k, r in enumerate(pts):
            if group == "IC-CG tol":
                ax.annotate("tol " + r["label"].split("=")[1], (r["wall_s"], 100 * r["error"]),
                            xytext=(0, -12 - 8 * (k % 3)), textcoords="offset points", fontsize=6, color=colour,
                            ha="center", arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.4})
            elif group == "IC-CG gamma":
                ax.annotate("γ " + r["label"].split("=")[1], (r["wall_s"], 100 * r["error"]),
                            xytext=(0, 10 + 8 * (k % 3)), textcoords="offset points", fontsize=6, color=colour,
                            ha="center", arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.4})
    # One label per spacing, right of its slowest point at the default tolerance.
    for across in sorted({r["across"] for r in rows if r["status"] == "ran"}):
        pts = [r for r in rows if r["status"] == "ran" and r["across"] == across
               and r["group"] in {b[0] for b in BACKENDS}]
        if pts:
            far = max(pts, key=lambda r: r["wall_s"])
            ax.annotate(f"{across} across", (far["wall_s"], 100 * far["error"]), xytext=(8, -2),
                        textcoords="offset points", fontsize=7)
    front = pareto(rows)
    ax.plot([r["wall_s"] for r in front], [100 * r["error"] for r in front], "-", color="grey", lw=1, zorder=2,
            label="non-dominated (Pareto front)")
    defaults = [r for r in rows if r["app_default"] and r["status"] == "ran"]
    if defaults:
        ax.scatter([r["wall_s"] for r in defaults], [100 * r["error"] for r in defaults], marker="*", s=220,
                   facecolors="none", edgecolors="tab:blue", zorder=4, label=f"app defaults, spacing included ({s['default_across']} across)")
    for level in (1.0, 0.1):
        ax.axhline(level, color="grey", ls=":", lw=0.8)
        ax.annotate(f"{level:g} %", (1, level), xycoords=("axes fraction", "data"), xytext=(-2, 2),
                    textcoords="offset points", ha="right", fontsize=7, color="grey")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of the whole run [s] (one process, one thread)")
    ax.set_ylabel(s["error"])
    failed = [r for r in rows if r["status"] != "ran"]
    note = f"; {len(failed)} run(s) failed (CSV)" if failed else ""
    ax.set_title(f"{s['title']}: error against wall time\n"
                 f"tol / γ variants: IC-CG warm at {s['middle']} across; errors within {SAME_ERROR:g} (relative) count as "
                 f"equal for the front{note}\n{run_stamp}",
                 fontsize=8)
    ax.legend(fontsize=7, loc="best")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    fig.tight_layout()
    fig.savefig(png, dpi=80)
    plt.close(fig)


def describe(r):
    cold = ", cold start" if not r["warm_start"] else ""
    return f"{r['solver']}{cold}, gamma {r['gamma']}, {r['across']} across ({r['label']})"


def report(scene, rows):
    ok = [r for r in rows if r["status"] == "ran"]
    print(f"\n== {scene}: {len(ok)} of {len(rows)} runs finished")
    for level in (0.01, 0.001):
        reach = [r for r in ok if r["error"] <= level]
        if not reach:
            best = min(ok, key=lambda r: r["error"]) if ok else None
            extra = f" (smallest error {100 * best['error']:.3f} %: {describe(best)})" if best else ""
            print(f"{scene}: no setting reached {100 * level:g} % error{extra}")
            continue
        fast = min(reach, key=lambda r: r["wall_s"])
        print(f"{scene}: fastest to {100 * level:g} % error: {describe(fast)}: {fast['wall_s']:.2f} s, "
              f"error {100 * fast['error']:.3f} %")
        base = [r for r in reach if r["baseline"]]
        if base:
            b = min(base, key=lambda r: r["wall_s"])
            print(f"{scene}:   baseline (IC-CG cold) to {100 * level:g} %: {b['wall_s']:.2f} s at {b['across']} across "
                  f"(error {100 * b['error']:.3f} %); baseline / fastest = {b['wall_s'] / fast['wall_s']:.2f}")
        else:
            print(f"{scene}:   the baseline (IC-CG cold) did not reach {100 * level:g} %")
    # Equal error: at one spacing every backend at tol 1e-8 gives the same error to a few digits.
    for across in sorted({r["across"] for r in ok if r["baseline"]}):
        same = [r for r in ok if r["across"] == across and r["group"] in {b[0] for b in BACKENDS}]
        b = next(r for r in same if r["baseline"])
        fast = min(same, key=lambda r: r["wall_s"])
        spread = max(r["error"] for r in same) - min(r["error"] for r in same)
        print(f"{scene}:   {across} across, tol 1e-8: baseline {b['wall_s']:.2f} s, fastest {fast['label']} "
              f"{fast['wall_s']:.2f} s: ratio {b['wall_s'] / fast['wall_s']:.2f} (errors {100 * b['error']:.4f} % and "
              f"{100 * fast['error']:.4f} %; spread over the backends {100 * spread:.2g} %-points)")


KEYS = ["scene", "label", "group", "across", "solver", "spec", "warm_start", "gamma", "status", "error", "wall_s",
        "sim_s", "solver_setup_s", "solve_s", "steps", "particles", "app_default", "baseline", "pareto"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build", help="build directory holding apps/poiseuille/poiseuille and apps/rotating/rotating")
    ap.add_argument("--full", action="store_true", help="more spacings; tolerance and gamma at every spacing")
    ap.add_argument("--defaults", action="store_true",
                    help="also run the app defaults at the app's own spacing when the sweep lacks it (poiseuille 50, "
                         "couette 20 across: ~2 min more)")
    ap.add_argument("--scenes", default="poiseuille,couette")
    ap.add_argument("--runs", default="runs/pareto", help="where the apps write their outputs")
    ap.add_argument("--results", default="bench/results", help="where the CSV and PNG go")
    a = ap.parse_args()
    run_stamp = (f"{stamp.sweep('numbers')}; {'full' if a.full else 'quick'} sweep"
                 f"{' + app defaults' if a.defaults else ''}")
    os.makedirs(a.results, exist_ok=True)
    start = time.perf_counter()
    all_rows = {}
    for scene in a.scenes.split(","):
        if scene not in SCENES:
            sys.exit(f"unknown scene '{scene}'; valid: {', '.join(SCENES)}")
        rows = [run_one(a.build, r, a.runs) for r in settings(scene, a.full, a.defaults)]
        front = {id(r) for r in pareto(rows)}
        for r in rows:
            r["pareto"] = id(r) in front
            r["solver_setup_s"] = r.pop("setup_s", "")
        csv_path = os.path.join(a.results, f"pareto_{scene}.csv")
        with open(csv_path, "w", newline="") as f:
            f.write(f"# {run_stamp}\n")
            w = csv.DictWriter(f, fieldnames=KEYS, extrasaction="ignore")
            w.writeheader()
            w.writerows(rows)
        png = os.path.join(a.results, f"pareto_{scene}.png")
        plot(scene, rows, png, run_stamp)
        print("wrote", csv_path, png, flush=True)
        all_rows[scene] = rows
    for scene, rows in all_rows.items():
        report(scene, rows)
    print(f"\nsweep took {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
