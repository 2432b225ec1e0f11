#!/usr/bin/python3
"""The apps under mpirun (docs/scaling.md): the same command on 1 process and on 2 and 3 ranks gives the same run.

For each case the app runs plainly, then under `mpirun -np P`, with hypre-pcg at a relative residual of 1e-10. Asserted:
the exit status, step count and particle counts agree; frame and sample times agree to TIME_RELATIVE (dt follows
|u|max); rank 0 wrote every output the serial run wrote (one summary, one set of frames, the same .pvd times); the
last frame's particles, matched by id, agree in position to POSITION_L0 of l0 and in pressure to PRESSURE of the
largest pressure; and the sampled series agree to the same bound in their units (the dam break's front.csv to
POSITION_L0 l0, the channel's profile.csv to POSITION_L0 U), as written, to 10 digits. So do the water levels of the
dam breaks' probes (--probes: rank 0 samples the gathered particles), in l0. The bounds are those of
tests/mpi/test_distributed_step.cpp (a solve at tol 1e-10 is within cond(A) tol ~ 1e-7 of the largest pressure; the
correction then moves particles by at most ~2e-9 l0 a step, 2e-7 l0 over 100 steps). Each case runs about 100 steps.

  tests/apps_on_ranks.py BUILD_DIR MPIEXEC RANKS
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

POSITION_L0 = 2e-7
PRESSURE = 2e-7
TIME_RELATIVE = 1e-9
SOLVER = "hypre-pcg:tol=1e-10"
# app: (options, l0 [m], its .pvd, the series compared column by column: file and the factor taking its values to
# the bound's units, l0 for lengths, U for velocities)
CASES = {
    # With probes (docs/probes.md): rank 0 samples the gathered particles; the water levels, in m.
    "dambreak": ("--column classic --dx 0.0073 --end-time 0.0610 --frames 2 --probes {probes2}", 0.0073,
                 "dambreak.pvd", [("front.csv", 20.0), ("probes.csv", 1 / 0.0073)]),  # x / a, a = 20 l0
    # The inlet channel at 10 across: its plate, ghost pool and outflow buffer; the profile at the station summed over
    # the ranks (u / U, averaged over the last 0.5 D/U).
    # SPHERIC Test 2 in 3-D at its coarsest spacing, past P1's first rise: the gauges' heights, in m (l0 = 0.1 m)
    "dambreak-3d": ("--dim 3 --dx 0.1 --end-time 0.6 --frames 2 --probes {probes3}", 0.1, "dambreak.pvd",
                    [("level.csv", 10.0), ("probes.csv", 10.0)]),
    "poiseuille": ("--mode inlet --re 40 --across 10 --end-time 1.5 --profiles 1 --average 0.5 --frames 2", 0.02,
                   "channel.pvd", [("profile.csv", 1.0)]),
}


def read_frame(path: Path) -> dict:
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    if reader.GetErrorCode():
        raise RuntimeError(f"VTK could not read {path}")
    data = reader.GetOutput()
    arrays = data.GetPointData()
    ids = vtk_to_numpy(arrays.GetArray("id"))
    order = np.argsort(ids)
    return {"id": ids[order], "xyz": vtk_to_numpy(data.GetPoints().GetData())[order],
            "p": vtk_to_numpy(arrays.GetArray("pressure"))[order]}


def frames_of(pvd: Path) -> list:
    return [(float(d.get("timestep")), pvd.parent / d.get("file")) for d in ET.parse(pvd).getroot().iter("DataSet")]


def run(command: list, out: Path) -> int:
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1")
    done = subprocess.run(command + ["--out", str(out)], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=600)
    if not (out / "summary.json").exists():
        raise AssertionError(f"{' '.join(command)} wrote no summary:\n{done.stdout[-3000:]}")
    return done.returncode


def main() -> int:
    build, mpiexec, ranks = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        probes = {"probes2": Path(tmp) / "levels2.toml", "probes3": Path(tmp) / "levels3.toml"}
        probes["probes2"].write_text('interval = 0.01\n[[probe]]\nname = "h"\nquantity = "level"\n'
                                     'points = [[0.05, 0.0], [0.16, 0.0]]\n')
        probes["probes3"].write_text('interval = 0.05\n[[probe]]\nname = "h"\nquantity = "level"\nmethod = "wire"\n'
                                     'points = [[2.9, 0.5, 0.0], [2.3, 0.5, 0.0]]\n')
        for case, (options, l0, pvd, series) in CASES.items():
            app = case.removesuffix("-3d")
            binary = str(build / "apps" / app / app)
            command = [binary] + options.format(**probes).split() + ["--solver", SOLVER]
            serial_out, ranks_out = Path(tmp) / f"{case}_serial", Path(tmp) / f"{case}_ranks"
            status = run(command, serial_out)
            status_ranks = run([mpiexec, "--oversubscribe", "--mca", "btl", "self,vader", "-np", str(ranks)] + command,
                               ranks_out)

            def check(ok, what):
                if not ok:
                    failures.append(f"{case} on {ranks} ranks: {what}")
                return ok

            check(status == status_ranks, f"exit status {status_ranks}, serially {status}")
            a = json.loads((serial_out / "summary.json").read_text())
            b = json.loads((ranks_out / "summary.json").read_text())
            check(b["parameters"].get("ranks") == ranks, f"the summary records ranks {b['parameters'].get('ranks')}")
            for key in ("steps", "particles", "status"):
                check(a[key] == b[key], f"summary {key} {b[key]}, serially {a[key]}")
            check(sorted(p.name for p in serial_out.iterdir()) == sorted(p.name for p in ranks_out.iterdir()),
                  "rank 0 wrote other files than the serial run")
            fa, fb = frames_of(serial_out / pvd), frames_of(ranks_out / pvd)
            # dt follows |u|max, which differs by round-off: times agree to TIME_RELATIVE.
            if not check(len(fa) == len(fb) and np.allclose([t for t, _ in fa], [t for t, _ in fb], rtol=TIME_RELATIVE,
                                                            atol=0), "the frames' times differ"):
                continue
            last_a, last_b = read_frame(fa[-1][1]), read_frame(fb[-1][1])
            if not check(np.array_equal(last_a["id"], last_b["id"]), "the last frame holds other particles"):
                continue
            position = np.max(np.linalg.norm(last_a["xyz"] - last_b["xyz"], axis=1)) / l0
            largest = np.max(np.abs(last_a["p"]))
            pressure = np.max(np.abs(last_a["p"] - last_b["p"])) / largest
            worst_series = 0.0
            for name, unit_l0 in series:
                rows_a = list(csv.reader(open(serial_out / name)))
                rows_b = list(csv.reader(open(ranks_out / name)))
                check(rows_a[0] == rows_b[0] and len(rows_a) == len(rows_b), f"{name}: other columns or rows")
                values_a = np.array(rows_a[1:], dtype=float)
                values_b = np.array(rows_b[1:], dtype=float)
                check(np.allclose(values_a[:, 0], values_b[:, 0], rtol=TIME_RELATIVE, atol=0), f"{name}: other sample times")
                worst_series = max(worst_series, np.max(np.abs(values_a[:, 1:] - values_b[:, 1:])) * unit_l0)
            print(f"{case} on {ranks} ranks, {a['steps']} steps: last frame max |r - r_serial| = {position:.3g} l0, "
                  f"max |p - p_serial| = {pressure:.3g} of {largest:.4g} Pa; series max difference {worst_series:.3g}")
            check(position <= POSITION_L0, f"positions differ by {position:.3g} l0 (bound {POSITION_L0})")
            check(pressure <= PRESSURE, f"pressures differ by {pressure:.3g} of the largest (bound {PRESSURE})")
            check(worst_series <= POSITION_L0, f"series differ by {worst_series:.3g} (bound {POSITION_L0})")
    for failure in failures:
        print("FAIL:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
