#!/usr/bin/python3
"""An app's default run passes its own check (docs/testing.md): run with no option but --out, it exits 0 and its
summary.json says pass, with status "passed" where the app checks its result against a reference (hydrostatic,
dambreak, structure) and "completed" where it has no check of its own (acoustic, fsi). One ctest per app
(DefaultRuns.<app>). The dam break's front is checked here as well, from its front.csv and Martin & Moyce's data
alone: the classic column at a/40 to T = 3.5, its developed speed (a line over T in [1.5, 3.5]) within 3 % of both
series' fitted the same way, within 2 % of the larger column's series after one fitted delay (which is a lead: the
experiments' release took time), no fluid lost but as counted spray and none inside a wall. rotating's and
poiseuille's defaults take 107 s and 70 s on one core and are not run here: poiseuille's is `make demo`'s run.

  tests/default_runs.py BUILD_DIR APP
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHECKED = {"hydrostatic", "dambreak", "structure"}


def main(build, app):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / app
        done = subprocess.run([str(Path(build) / "apps" / app / app), "--out", str(out)], capture_output=True,
                              text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
        print(done.stdout[-1500:])
        if done.returncode != 0:
            sys.exit(f"FAIL: {app}'s default run exited {done.returncode}:\n{done.stderr[-1500:]}")
        summary = json.loads((out / "summary.json").read_text())
        status = "passed" if app in CHECKED else "completed"
        if summary["status"] != status or summary["pass"] is not True:
            sys.exit(f"FAIL: {app}'s default run's summary says {summary['status']}, pass {summary['pass']}")
        if app == "dambreak":
            check_classic_front(out, summary)
    print(f"PASS: {app}'s default run exits 0, {status}")


def fitted_speed(T, x):
    """The slope of the least-squares line through the points with T in [1.5, 3.5]."""
    inside = (T >= 1.5) & (T <= 3.5)
    return np.polyfit(T[inside], x[inside], 1)[0]


def check_classic_front(out, summary):
    """The classic column's front against Martin & Moyce (measured: speed 1.61 and 1.86 % off, 1.25 % after a delay of
    0.242)."""
    params = summary["parameters"]
    if params["column"] != "classic" or abs(params["dx_m"] - params["column_width_m"] / 40) > 1e-12:
        sys.exit(f"FAIL: the dam break's default is no longer the classic column at a/40: {params['column']}, "
                 f"{params['dx_m']} m")
    run = np.genfromtxt(out / "front.csv", delimiter=",", names=True)
    T, x = run["T"], run["x_over_a"]
    # The last step ends at or past T = 3.5 (a step is about 0.003 in T at a/40), never before.
    if not 3.5 - 1e-9 <= T[-1] < 3.51:
        sys.exit(f"FAIL: the run ended at T = {T[-1]}, not within a step after 3.5")
    speed = fitted_speed(T, x)
    data = Path(params["data"])
    for name in ("mm_data_1.txt", "mm_data_2.txt"):
        te, xe = np.loadtxt(data / name, unpack=True)
        theirs = fitted_speed(te, xe)
        print(f"front speed {speed:.4f} against {name}'s {theirs:.4f}: {100 * (speed / theirs - 1):+.2f} %")
        if not abs(speed - theirs) <= 0.03 * theirs:
            sys.exit(f"FAIL: the front's developed speed {speed} is not within 3 % of {name}'s {theirs}")
    # One delay dT for the whole larger series, every point up to T = 3.5 compared (the delayed run must reach it).
    te, xe = np.loadtxt(data / "mm_data_2.txt", unpack=True)
    te, xe = te[te <= 3.5], xe[te <= 3.5]
    delays = [d for d in np.arange(-500, 1001) * 1e-3 if (te - d).max() <= T[-1]]
    errors = [np.max(np.abs(np.interp(te - d, T, x) / xe - 1)) for d in delays]
    best = int(np.argmin(errors))
    print(f"after a delay of {delays[best]:.3f}: within {100 * errors[best]:.2f} % of mm_data_2.txt")
    if not (errors[best] < 0.02 and delays[best] > 0.1):
        sys.exit(f"FAIL: the front's shape is {errors[best]} off the larger column's after a delay {delays[best]}")
    checks, fluid = summary["checks"], summary["particles"]["fluid"]
    # The walls hold this flow on their own: the backstop for fluid slipping into a wall never acts.
    returned = checks["fluid_returned_to_a_face_count"]
    if fluid + checks["fluid_removed_as_spray_count"] != 40 * 80 or checks["most_fluid_inside_walls_count"] != 0 \
            or returned != 0:
        sys.exit(f"FAIL: {fluid} fluid particles + {checks['fluid_removed_as_spray_count']} removed as spray, not the "
                 f"column's 40 x 80; {checks['most_fluid_inside_walls_count']} inside a wall, {returned} put back "
                 "from inside a wall by the backstop")


if __name__ == "__main__":
    main(*sys.argv[1:3])
