#!/usr/bin/python3
"""--export-ppe and solves.csv: a short channel run exports the PPE of two of its steps. The matrix must be the
symmetric positive definite system its header says, of the size solves.csv gives for that step, with the scene's
spacing, radius and gamma in the header; solves.csv has one row per step, each solve to the solver's tolerance; a
second run writes the same bytes.

  tests/export_ppe.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ARGS = "--mode body-force --across 10 --end-time 0.3 --frames 0 --gamma 0.5 --export-ppe 1,3".split()


def run(build, out):
    cmd = [str(Path(build) / "apps" / "poiseuille" / "poiseuille"), *ARGS, "--out", str(out)]
    return subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True).returncode


def read_symmetric(path):
    lines = path.read_text().splitlines()
    header = [line for line in lines if line.startswith("%")]
    body = [line for line in lines if not line.startswith("%")]
    n, m, entries = map(int, body[0].split())
    a = np.zeros((n, m))
    for line in body[1:1 + entries]:
        i, j, v = line.split()
        a[int(i) - 1, int(j) - 1] = float(v)
        a[int(j) - 1, int(i) - 1] = float(v)
    return header, a, entries


def main():
    build = sys.argv[1]
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        first, again = Path(tmp) / "first", Path(tmp) / "again"
        for out in (first, again):
            if run(build, out) not in (0, 2):
                print("FAIL the run did not finish")
                return 1
        summary = json.loads((first / "summary.json").read_text())
        rows = (first / "solves.csv").read_text().splitlines()
        columns = rows[0].split(",")
        table = [dict(zip(columns, row.split(","))) for row in rows[1:]]
        if [int(r["step"]) for r in table] != list(range(1, summary["steps"] + 1)):
            failures.append(f"solves.csv steps {[r['step'] for r in table]} for a run of {summary['steps']} steps")
        for r in table:
            if float(r["relative_residual"]) > 1e-8 or int(r["unknowns"]) <= 0:
                failures.append(f"solves.csv row {r}")
        l0 = summary["parameters"]["dx_m"]
        for step in (1, 3):
            header, a, entries = read_symmetric(first / "ppe" / f"step_{step:06d}.mtx")
            b = np.loadtxt(first / "ppe" / f"step_{step:06d}_rhs.mtx", comments="%", skiprows=3)
            text = "\n".join(header)
            if not header[0].endswith("coordinate real symmetric"):
                failures.append(f"step {step}: banner {header[0]!r}")
            for expected in (f"step {step},", f"l0 = {l0:.15g} m", "Laplacian radius = 4.1 l0", "gamma = 0.5",
                             "A = -(discrete Laplacian)"):
                if expected not in text:
                    failures.append(f"step {step}: header lacks {expected!r}")
            n = int(table[step - 1]["unknowns"])
            if a.shape != (n, n) or b.shape != (n,):
                failures.append(f"step {step}: A {a.shape}, b {b.shape}, solves.csv says {n} unknowns")
            if entries >= np.count_nonzero(a):
                failures.append(f"step {step}: {entries} entries stored for {np.count_nonzero(a)}: not the triangle")
            eigenvalues = np.linalg.eigvalsh(a)
            if eigenvalues.min() <= 0:
                failures.append(f"step {step}: smallest eigenvalue {eigenvalues.min()}")
            if np.allclose(b, 0):
                failures.append(f"step {step}: b is zero")
            print(f"step {step}: {n} unknowns, {entries} stored entries, eigenvalues {eigenvalues.min():.3g} .. "
                  f"{eigenvalues.max():.3g}")
        for name in ("ppe/step_000001.mtx", "ppe/step_000003.mtx", "ppe/step_000003_rhs.mtx"):
            if (first / name).read_bytes() != (again / name).read_bytes():
                failures.append(f"{name} differs between two runs")
        # A step beyond the run's end is said, not passed over in silence.
        steps = summary["steps"]
        cmd = [str(Path(build) / "apps" / "poiseuille" / "poiseuille"),
               *[a for a in ARGS if a != "1,3"][:-1], "--export-ppe", f"2,{steps + 5000}", "--out", str(Path(tmp) / "late")]
        late = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
        said = f"--export-ppe {steps + 5000}: the run ended after step {steps}"
        if said not in late.stderr or not (Path(tmp) / "late" / "ppe" / "step_000002.mtx").exists():
            failures.append(f"--export-ppe beyond the end: expected {said!r}, stderr {late.stderr[-300:]!r}")
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
