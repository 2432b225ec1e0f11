#!/usr/bin/python3
"""The frames as VTK's own reader (vtkXMLPolyDataReader, Debian's python3-vtk9) sees them.

1. Known particles (tests/write_known_frames.cpp): every point and array VTK reads equals, bit for bit, the value the
   C++ side wrote (also when an array ends in a partial zlib block, fills its blocks exactly, or is empty); TIME is the
   frame's time, and is what the reader reports as the frame's time step when TIME is its time array (as ParaView's
   "Time Array" does); vectors have 3 components.
2. Every app: a run with --frames 3, then a second run into the same --out with --frames 1. Afterwards the frames on disk
   are exactly those the second run's .pvd lists (none of the first run's left behind), each frame's TIME equals the
   time the .pvd gives it, velocity (and rotating's relative_velocity) has 3 components.

  tests/read_frames_vtk.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

# Small runs of every app (a second or two each); --frames is added per run.
APPS = {
    "poiseuille": "--mode body-force --across 10 --end-time 1",
    "hydrostatic": "--end-time 0.1 --window 0.05",
    "rotating": "--scene channel --model moving --across 8 --times 0.05",
    "acoustic": "--case hard --size 20 --l0 0.5 --end-time 0.05 --no-maps",
    "dambreak": "--column classic --end-time 0.05",
    "structure": "--scene csm3 --end-time 0.05",
    "fsi": "--scene gate --end-time 0.01",
}
VECTORS = {"rotating": ["velocity", "relative_velocity"]}


def read(path: Path):
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    if reader.GetErrorCode():
        raise RuntimeError(f"VTK could not read {path}")
    return reader.GetOutput()


def time_step_reported(path: Path) -> list:
    """The time steps the reader announces when TIME is its time array, as ParaView's XML readers can be set to."""
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.SetActiveTimeDataArrayName("TIME")
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    key = vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    return [info.Get(key, k) for k in range(info.Length(key))] if info.Has(key) else []


def bits(values) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=np.float64).view(np.uint64).ravel()


def known_frame_errors(path: Path, expected: dict) -> list:
    errors = []
    data = read(path)
    hexes = lambda key: np.array([float.fromhex(h) for h in key], dtype=np.float64)  # noqa: E731
    n = len(expected["scalars"]["pressure"])
    if data.GetNumberOfPoints() != n or data.GetNumberOfVerts() != n:
        errors.append(f"{data.GetNumberOfPoints()} points, {data.GetNumberOfVerts()} vertices, expected {n}")
    points = vtk_to_numpy(data.GetPoints().GetData()) if n else np.zeros(0)
    if not np.array_equal(bits(points), bits(hexes(expected["points"]))):
        errors.append("points differ")
    point_data = data.GetPointData()
    for group, components in (("vectors", 3), ("scalars", 1)):
        for name, values in expected[group].items():
            array = point_data.GetArray(name)
            if array is None:
                errors.append(f"no array {name}")
                continue
            if array.GetNumberOfComponents() != components:
                errors.append(f"{name} has {array.GetNumberOfComponents()} components, expected {components}")
            if not np.array_equal(bits(vtk_to_numpy(array)), bits(hexes(values))):
                errors.append(f"{name} differs")
    for name, values in expected["integers"].items():
        array = point_data.GetArray(name)
        if array is None or not np.array_equal(vtk_to_numpy(array).ravel(), np.array(values, dtype=np.int64)):
            errors.append(f"{name} differs")
    if point_data.GetScalars() is None or point_data.GetScalars().GetName() != "pressure":
        errors.append("pressure is not the active scalar")
    if point_data.GetVectors() is None or point_data.GetVectors().GetName() != "velocity":
        errors.append("velocity is not the active vector")
    time = data.GetFieldData().GetArray("TIME")
    want = float.fromhex(expected["time"])
    if time is None or time.GetNumberOfTuples() != 1 or bits([time.GetValue(0)])[0] != bits([want])[0]:
        errors.append(f"TIME {None if time is None else time.GetValue(0)!r}, expected {want!r}")
    if time_step_reported(path) != [want]:
        errors.append(f"time steps with TIME as the time array: {time_step_reported(path)}, expected [{want!r}]")
    return [f"{path.name}: {e}" for e in errors]


def run(build: Path, app: str, args: str, frames: int, out: Path) -> None:
    cmd = [str(build / "apps" / app / app), *args.split(), "--frames", str(frames), "--out", str(out)]
    proc = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    if proc.returncode not in (0, 2):  # 2: ran, its accuracy check failed at this size
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {proc.stderr[-1000:]}")


def listed_frames(out: Path) -> dict:
    """The time each .pvd in `out` gives each of its frames, by the frame's resolved path."""
    listed = {}
    for pvd in out.rglob("*.pvd"):
        for ds in ET.parse(pvd).getroot().iter("DataSet"):
            listed[(pvd.parent / ds.get("file")).resolve()] = float(ds.get("timestep"))
    return listed


def app_frame_errors(app: str, out: Path, first_run_frames: int) -> list:
    errors = []
    listed = listed_frames(out)
    on_disk = {f.resolve() for f in out.rglob("*.vtp") if f.name != "last_good.vtp"}
    if on_disk != set(listed):
        errors.append(f"frames on disk {sorted(f.name for f in on_disk)}, the .pvd lists "
                      f"{sorted(f.name for f in listed)}")
    if not 0 < len(listed) < first_run_frames:
        errors.append(f"{len(listed)} frames listed, the first run wrote {first_run_frames}: not fewer")
    for frame, t in sorted(listed.items()):
        if not frame.exists():
            continue
        data = read(frame)
        time = data.GetFieldData().GetArray("TIME")
        if time is None or time.GetValue(0) != t:
            errors.append(f"{frame.name}: TIME {None if time is None else time.GetValue(0)!r}, the .pvd {t!r}")
        if data.GetNumberOfPoints() == 0 or data.GetNumberOfVerts() != data.GetNumberOfPoints():
            errors.append(f"{frame.name}: {data.GetNumberOfPoints()} points, {data.GetNumberOfVerts()} vertices")
        for name in VECTORS.get(app, ["velocity"]):
            array = data.GetPointData().GetArray(name)
            if array is None or array.GetNumberOfComponents() != 3:
                errors.append(f"{frame.name}: {name} is not a 3-component array")
    return [f"{app}: {e}" for e in errors]


def main() -> int:
    build = Path(sys.argv[1])
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        known = Path(tmp) / "known"
        subprocess.run([str(build / "tests" / "write_known_frames"), str(known)], check=True)
        for frame in sorted(known.glob("*.vtp")):
            expected = json.loads(frame.with_suffix(".json").read_text())
            found = known_frame_errors(frame, expected)
            print(f"{frame.name}: {len(expected['scalars']['pressure'])} points read back",
                  "bitwise" if not found else "WRONG")
            failures += found
        for app, args in APPS.items():
            out = Path(tmp) / app
            run(build, app, args, 3, out)
            first_run_frames = len(listed_frames(out))
            run(build, app, args, 1, out)  # fewer frames into the same --out
            found = app_frame_errors(app, out, first_run_frames)
            print(f"{app}: {'frames as listed, TIME and vectors right' if not found else 'WRONG'}")
            failures += found
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
