"""Stability maps (design section 7): gamma x time-step factor, each cell classified as

  stable      the run reached its end time and its error is within the scene's bound,
  inaccurate  the run reached its end time but its error is over the bound,
  blown up    the stability guard stopped the run (the app's exit status 1 with summary.json status "failed").

The time-step factor is the apps' --dt-factor: it multiplies both the CFL (0.2) and the viscous (0.2) limits, so
1 is each app's default step and the map is unit-free. gamma 0, 0.01, 0.05, 0.1, 0.5, 0.99, 1 in both scenes; factors
0.25 ... 3 for the inlet channel (CFL-limited: from 2.5 on the first step moves the fastest particle 0.5 l0, the guard's
limit) and 0.25 ... 8 for the screw channel (viscous-limited). Scenes and their errors:

  inlet    apps/poiseuille --mode inlet --re 400, 20 across, a 4 D channel with the station at 3 D, to 2 D/U,
           profile averaged over the last 1 D/U. Error: the flow-rate error at the station, |Q - U D| / (U D), i.e.
           mass conservation. The peak-velocity check of the app (against the developed parabola) is meaningless
           here: at Re 400 the flow at the station is still in the entrance region. Bound: 2 %, the app's default
           --tolerance (which it applies to the peak error).
  channel  apps/rotating --scene channel --model moving (the screw channel, scene defaults: corrected gradient,
           initial reference density, shifting A = 1), 16 across, to t = 0.5 s (half a diffusion time), curves averaged over the
           second half, as in the test RotatingChannel.SteadyFlowIsSymmetricAtReOne. Error: the
           arc-2 odd defect, max |u_r(phi) + u_r(-phi)| / (omega R) over |phi| <= 0.4, the symmetry the steady
           flow has exactly; bound 0.03, the app's own check (--agreement) and the test's. A run with fluid
           particles outside the channel also counts as inaccurate.

Beside the error the CSV records, without using it to classify, each run's deviation from a reference run: the
station profile (inlet, max |u - u_ref| / U, reference gamma 0.99 at factor 0.5) or line 1 (channel, max
|u_theta - u_ref| / (omega R), reference gamma 0.01 at factor 0.25), and for the channel the barrel pressure's odd
defect over its range.

usage: make bench-stability, or OMP_NUM_THREADS=1 /usr/bin/python3 bench/stability_maps.py BUILD_DIR [--scenes inlet,channel]
           [--gammas 0,0.01,...] [--factors 0.25,...] [--runs runs/stability] [--results bench/results]

Runs the grid one process at a time and writes RESULTS/stability_<scene>.csv and .png. The CSV holds only what the
apps computed (deterministic with one thread); the wall times are printed, not stored.
"""
import argparse
import csv
import math
import os
import shutil
import sys
import time

import stamp
from runapp import run_app

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch

GAMMAS = [0.0, 0.01, 0.05, 0.1, 0.5, 0.99, 1.0]

SCENES = {
    "inlet": {
        "app": "apps/poiseuille/poiseuille",
        "args": ["--mode", "inlet", "--re", "400", "--across", "20", "--channel-length", "4", "--station", "3",
                 "--end-time", "2", "--average", "1", "--profiles", "1", "--frames", "0"],
        "title": "Inlet channel, Re 400, 20 across, 4 D long, station 3 D, to 2 D/U",
        "error_name": "flow-rate error at the station |Q - UD| / UD",
        "bound": 0.02,
        # dt = 0.2 x factor x l0 / max|u| and the guard stops a move over 0.5 l0: from a factor of 2.5 on, the
        # fastest particle is stopped at its first step unless it slows down.
        "factors": [0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0],
        "percent": True,
        "app_default": (0.99, 1.0),
        # Recorded beside the error, not used to classify: max |u - u_ref| / U of the station profile against the
        # run at the app's gamma and the smallest factor that ran there.
        "reference": (0.99, 0.5), "curve": "profile.csv",
    },
    "channel": {
        "app": "apps/rotating/rotating",
        "args": ["--scene", "channel", "--model", "moving", "--across", "16", "--times", "0.5", "--average", "0.5",
                 "--frames", "0"],
        "title": "Screw channel (moving model), 16 across, to t = 0.5 s",
        "error_name": "arc-2 odd defect max |u_r(φ) + u_r(-φ)| / ωR over |φ| ≤ 0.4",
        "bound": 0.03,
        # The viscous limit sets dt here (nu = 1, 16 across); docs/numerics.md found viscous number 1.0 (factor 5)
        # stable and 1.6 (factor 8) stopped by the guard.
        "factors": [0.25, 0.5, 1.0, 2.0, 4.0, 6.0, 8.0],
        "percent": False,
        "app_default": (0.01, 1.0),
        # Recorded, not used to classify: max |u_theta - u_theta,ref| / (omega R) on line 1 against the run at the
        # scene's gamma and a quarter of the default step; and the barrel pressure's odd defect over its range.
        "reference": (0.01, 0.25), "curve": "line1.csv",
    },
}

CLASSES = ["stable", "inaccurate", "blown up", "error"]
COLOURS = ["#4daf4a", "#ffb000", "#e41a1c", "#999999"]


def error_of(scene, summary):
    if scene == "inlet":
        return summary["flow_rate_error"]
    return summary["checks"]["arc2_odd_defect_over_omega_R2"]


def time_unit(scene, summary):
    """Time reached in the scene's unit: D/U for the inlet channel, s for the screw channel."""
    if scene == "inlet":
        p = summary["parameters"]
        return summary["time_s"] * p["velocity_scale_m_per_s"] / p["width_m"]
    return summary["time_s"]


def run_one(build, scene, gamma, factor, runs_dir):
    s = SCENES[scene]
    out = os.path.join(runs_dir, scene, f"g{gamma:g}_f{factor:g}")
    shutil.rmtree(out, ignore_errors=True)  # no stale summary.json from an earlier run
    cmd = [os.path.join(build, s["app"]), *s["args"], "--gamma", f"{gamma:g}", "--dt-factor", f"{factor:g}",
           "--out", out]
    proc, summary, wall = run_app(cmd, out)
    row = {"scene": scene, "gamma": gamma, "dt_factor": factor, "exit_status": proc.returncode, "error": math.nan,
           "steps": summary.get("steps", ""), "time_reached": "", "guard_message": "", "escaped": "", "note": "",
           "barrel_odd_defect": ""}
    if "time_s" in summary:
        row["time_reached"] = round(time_unit(scene, summary), 6)
    if proc.returncode in (0, 2) and "parameters" in summary and summary.get("status") != "failed":
        row["error"] = error_of(scene, summary)
        bad = row["error"] > s["bound"]
        if scene == "channel":
            row["escaped"] = summary["checks"]["max_escaped_fluid_particles"]
            row["barrel_odd_defect"] = round(summary["checks"]["barrel_pressure_odd_defect_over_range"], 6)
            if row["escaped"] != 0 or not summary["checks"]["fluid_count_kept"]:
                bad = True
                row["note"] = "fluid left the channel"
        else:
            row["note"] = "peak error %.4f, profile L2 %.4f" % (summary["peak_velocity_error"],
                                                                summary["profile_l2_error"])
        row["class"] = "inaccurate" if bad else "stable"
    elif proc.returncode == 1 and summary.get("status") == "failed" and "error" in summary:
        row["class"] = "blown up"
        row["guard_message"] = summary["error"]
    else:  # bad input or a crash: not a property of the method
        row["class"] = "error"
        row["guard_message"] = (proc.stderr.strip().splitlines() or ["exit %d" % proc.returncode])[-1]
    print("  gamma %-5g dt factor %-5g %-10s error %-10s t %-9s steps %-6s %6.1f s  %s" % (
        gamma, factor, row["class"], "%.5f" % row["error"] if not math.isnan(row["error"]) else "-",
        row["time_reached"], row["steps"], wall, row["guard_message"][:90]), flush=True)
    return row, wall


def cell_text(scene, r):
    s = SCENES[scene]
    if r["class"] == "blown up":
        unit = "D/U" if scene == "inlet" else "s"
        return f"guard: step {r['steps'] + 1}\nt = {r['time_reached']:.3g} {unit}"
    if r["class"] == "error":
        return "error"
    text = f"{100 * r['error']:.2f} %" if s["percent"] else f"{r['error']:.4f}"
    return text + ("\nescaped" if r["note"] == "fluid left the channel" else "")


def plot(scene, rows, gammas, factors, png, run_stamp):
    s = SCENES[scene]
    grid = [[CLASSES.index(next(r["class"] for r in rows if r["gamma"] == g and r["dt_factor"] == f))
             for f in factors] for g in gammas]
    fig, ax = plt.subplots(figsize=(8.2, 5.8))
    ax.imshow(grid, cmap=ListedColormap(COLOURS), vmin=-0.5, vmax=len(CLASSES) - 0.5, origin="lower",
              aspect="auto")
    for i, g in enumerate(gammas):
        for j, f in enumerate(factors):
            r = next(r for r in rows if r["gamma"] == g and r["dt_factor"] == f)
            ax.text(j, i, cell_text(scene, r), ha="center", va="center", fontsize=7)
    dg, df = s["app_default"]
    if dg in gammas and df in factors:
        ax.add_patch(plt.Rectangle((factors.index(df) - 0.5, gammas.index(dg) - 0.5), 1, 1, fill=False, lw=2,
                                   ec="black"))
    ax.set_xticks(range(len(factors)), [f"{f:g}" for f in factors])
    ax.set_yticks(range(len(gammas)), [f"{g:g}" for g in gammas])
    ax.set_xlabel("Δt factor (--dt-factor: multiplies the CFL 0.2 and viscous 0.2 limits)")
    ax.set_ylabel("γ (source: γ × density + (1 − γ) × divergence)")
    bound = f"{100 * s['bound']:g} %" if s["percent"] else f"{s['bound']:g}"
    counts = {c: sum(r["class"] == c for r in rows) for c in CLASSES}
    handles = [Patch(color=COLOURS[k], label=f"{c} ({counts[c]})") for k, c in enumerate(CLASSES)
               if counts[c] or c != "error"]
    handles.append(Patch(fill=False, ec="black", lw=2, label="app default"))
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"Stability map: {s['title']}\ninaccurate: {s['error_name']} > {bound}; "
                 f"blown up: stopped by the guard (t reached)\n{run_stamp}", fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=80)
    plt.close(fig)


KEYS = ["scene", "gamma", "dt_factor", "class", "error", "deviation_from_reference", "barrel_odd_defect", "exit_status",
        "steps", "time_reached", "escaped", "note", "guard_message"]


def read_curve(path):
    """The first value column of a curve CSV (profile.csv, line1.csv) against its axis."""
    with open(path) as f:
        rows = list(csv.reader(f))
    return {float(r[0]): float(r[1]) for r in rows[1:]}


def add_deviations(scene, rows, runs_dir):
    """deviation_from_reference: max |curve - reference curve| over the common, non-nan points; empty when the
    run or the reference did not finish or the reference is not in the grid."""
    s = SCENES[scene]
    g, f = s["reference"]
    ref_path = os.path.join(runs_dir, scene, f"g{g:g}_f{f:g}", s["curve"])
    ref_row = next((r for r in rows if r["gamma"] == g and r["dt_factor"] == f), None)
    for r in rows:
        r["deviation_from_reference"] = ""
    if ref_row is None or ref_row["class"] in ("blown up", "error") or not os.path.exists(ref_path):
        return
    ref = read_curve(ref_path)
    for r in rows:
        if r["class"] in ("blown up", "error"):
            continue
        cur = read_curve(os.path.join(runs_dir, scene, f"g{r['gamma']:g}_f{r['dt_factor']:g}", s["curve"]))
        d = [abs(v - ref[k]) for k, v in cur.items() if k in ref and not math.isnan(v) and not math.isnan(ref[k])]
        r["deviation_from_reference"] = round(max(d), 6) if d else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build", help="build directory holding apps/poiseuille/poiseuille and apps/rotating/rotating")
    ap.add_argument("--scenes", default="inlet,channel")
    ap.add_argument("--gammas", default=",".join(f"{g:g}" for g in GAMMAS))
    ap.add_argument("--factors", help="dt factors (default: the scene's list)")
    ap.add_argument("--runs", default="runs/stability", help="where the apps write their outputs")
    ap.add_argument("--results", default="bench/results", help="where the CSV and PNG go")
    a = ap.parse_args()
    gammas = [float(g) for g in a.gammas.split(",")]
    run_stamp = stamp.sweep("maps")
    os.makedirs(a.results, exist_ok=True)
    start = time.perf_counter()
    for scene in a.scenes.split(","):
        if scene not in SCENES:
            sys.exit(f"unknown scene '{scene}'; valid: {', '.join(SCENES)}")
        print(f"== {scene}: {SCENES[scene]['title']}", flush=True)
        t0 = time.perf_counter()
        factors = [float(f) for f in a.factors.split(",")] if a.factors else SCENES[scene]["factors"]
        rows = []
        for g in gammas:
            for f in factors:
                rows.append(run_one(a.build, scene, g, f, a.runs)[0])
        add_deviations(scene, rows, a.runs)
        csv_path = os.path.join(a.results, f"stability_{scene}.csv")
        with open(csv_path, "w", newline="") as fh:
            s = SCENES[scene]
            bound = f"{100 * s['bound']:g} %" if s["percent"] else f"{s['bound']:g}"
            rg, rf = s["reference"]
            barrel_note = ("; barrel_odd_defect: max |p(φ) + p(-φ)| over |φ| ≤ 0.4 / its range there (not used to "
                           "classify)") if scene == "channel" else ""
            fh.write(f"# {run_stamp}\n# {s['title']}; error: {s['error_name']}; inaccurate above {bound}; "
                     f"time_reached in {'D/U' if scene == 'inlet' else 's'}; deviation_from_reference: max abs "
                     f"difference of {s['curve']} from the run at gamma {rg:g}, dt factor {rf:g} (not used to "
                     f"classify){barrel_note}\n")
            w = csv.DictWriter(fh, fieldnames=KEYS, extrasaction="ignore")
            w.writeheader()
            w.writerows(rows)
        png = os.path.join(a.results, f"stability_{scene}.png")
        plot(scene, rows, gammas, factors, png, run_stamp)
        counts = ", ".join(f"{c} {sum(r['class'] == c for r in rows)}" for c in CLASSES)
        print(f"wrote {csv_path} {png}: {counts}; {time.perf_counter() - t0:.0f} s", flush=True)
    print(f"\nmaps took {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
