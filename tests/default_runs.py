#!/usr/bin/python3
"""An app's default run passes its own check (docs/testing.md): run with no option but --out, it exits 0 and its
summary.json says pass, with status "passed" where the app checks its result against a reference (hydrostatic,
dambreak, structure) and "completed" where it has no check of its own (acoustic, fsi). One ctest per app
(DefaultRuns.<app>). rotating's and poiseuille's defaults take 107 s and 70 s on one core and are not run here:
poiseuille's is `make demo`'s run.

  tests/default_runs.py BUILD_DIR APP
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

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
    print(f"PASS: {app}'s default run exits 0, {status}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
