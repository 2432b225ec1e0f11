#!/usr/bin/python3
"""Runs every scene at a small size and records what it computed, so a refactor can show its numbers did not move.

  scripts/compare_results.py record BUILD_DIR RECORD.json   # before the change
  scripts/compare_results.py check  BUILD_DIR RECORD.json   # after: exit 1 and list every difference

Recorded per case: the exit status, summary.json without its timings and run record (wall-clock figures and the
command line differ run to run), each frame (.vtp) by what it holds, and the SHA-256 of every other file the run
wrote (CSVs, .pvd). A frame is read with VTK's own reader (Debian's python3-vtk9) and recorded as its time and a
SHA-256 of each array's values as float64 (points, vertex cells, every point-data array with its component count), so
frames of any encoding compare equal when their numbers are: the ASCII frames written before 0.1.0's binary ones
agree bitwise with them (ASCII had 17 significant digits). A frame's time is its TIME field; frames from before TIME
existed take the time their .pvd lists. One OpenMP thread, so that reductions add in one order. Every summary is
also checked against docs/summary.schema.json (Debian's python3-jsonschema): a break is listed and fails a check.
"""
import functools
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

# name -> (app, arguments); each a few seconds at these sizes, except dambreak-seed-h50 (about 2 min).
CASES = {
    "demo-inlet-re40": ("poiseuille", "--mode inlet --re 40 --across 10 --end-time 3 --frames 2"),
    "inlet-re4-shifting-implicit": ("poiseuille", "--mode inlet --re 4 --across 10 --end-time 0.5 --frames 2 "
                                                  "--shifting 1 --implicit-viscosity"),
    "inlet-re400-open-end": ("poiseuille", "--mode inlet --re 400 --across 10 --end-time 2 --frames 2 "
                                           "--outlet-buffer 0 --compression 0 --solver hypre-pcg"),
    "body-force": ("poiseuille", "--mode body-force --across 10 --end-time 5 --frames 2"),
    "couette-channel": ("poiseuille", "--mode couette --across 10 --end-time 5 --frames 2 --solver cholmod"),
    "hydrostatic": ("hydrostatic", "--end-time 0.3 --window 0.1 --frames 2"),
    "hydrostatic-gamma0.01": ("hydrostatic", "--end-time 0.3 --window 0.1 --frames 2 --gamma 0.01"),
    "screw-channel-both": ("rotating", "--scene channel --model both --across 8 --times 0.05,0.1 --frames 2"),
    "screw-channel-plain-lattice": ("rotating", "--scene channel --model moving --across 8 --times 0.1 --frames 2 "
                                                "--walls plain --lattice-reference --shifting 0"),
    "taylor-couette": ("rotating", "--scene couette --across 8 --times 0.05,0.1 --frames 2"),
    **{f"acoustic-{c}": ("acoustic", f"--case {c} --size 20 --l0 0.5 --end-time 0.05 --no-maps --frames 2")
       for c in ("free", "hard", "mur", "flow")},
    "acoustic-two-pulse": ("acoustic", "--case two-pulse --size 40 --l0 0.5 --end-time 0.05 --no-maps --frames 2"),
    "dambreak-classic": ("dambreak", "--column classic --end-time 0.1 --frames 2"),
    "dambreak-seed-no-collisions": ("dambreak", "--column seed --end-time 0.3 --frames 2 --collision 0 --asymmetry 0"),
    # the seed column at its own spacing through both impacts: the other dam-break cases end before the impact, where
    # the wall pressure moves with the solver's last digits
    "dambreak-seed-h50": ("dambreak", "--column seed --dx 0.02 --frames 2"),
    "dambreak-classic-shifting-plain-gradient": ("dambreak", "--column classic --end-time 0.1 --frames 2 --shifting 1 "
                                                             "--gradient plain"),
    "dambreak-3d": ("dambreak", "--dim 3 --dx 0.08 --end-time 0.1 --frames 2"),
    "structure-plate": ("structure", "--scene plate --dx 0.004 --end-time 0.3 --frames 2"),
    "structure-plate-linear-no-hourglass": ("structure", "--scene plate --dx 0.004 --model linear --hourglass 0 "
                                                         "--end-time 0.1 --frames 2"),
    "structure-csm3": ("structure", "--scene csm3 --end-time 0.3 --frames 2"),
    "fsi-plate": ("fsi", "--end-time 0.16 --frames 2"),
    "fsi-plate-min-reference": ("fsi", "--end-time 0.16 --frames 2 --pressure-gradient min-reference --relaxation 0.1"),
    "fsi-gate": ("fsi", "--scene gate --end-time 0.01 --frames 2"),
    # a scene file: a moving obstacle, probes, and auto's Jacobi-CG rescue where AMG-PCG breaks down (from step 436)
    "scene-wave-paddle": ("run", str(Path(__file__).resolve().parent.parent / "examples" / "scenes" / "wave_paddle.toml") +
                          " --end-time 0.5 --frames 2"),
}
# Wall-clock figures differ run to run; "run" records the command line (its --out) and the commit, which a refactor
# changes by definition.
TIMING_KEYS = {"timings", "particle_steps_per_s", "particle_steps_per_second", "wall_s", "wall_seconds", "elapsed_s",
               "run"}
SCHEMA = Path(__file__).resolve().parent.parent / "docs" / "summary.schema.json"
SCHEMA_ERRORS = []  # every summary written, checked against the schema; not part of the record


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def comparable_bytes(path: Path) -> bytes:
    """A file's bytes less what differs between identical runs: config.toml's temporary out= line, solves.csv's
    wall-clock columns. config.toml's lines are sorted: TOML gives the order of keys no meaning, and --help's option
    groups set it."""
    if path.name == "config.toml":
        return "\n".join(sorted(l for l in path.read_text().splitlines() if not l.startswith("out="))).encode()
    if path.name == "solves.csv":
        rows = [line.split(",") for line in path.read_text().splitlines()]
        keep = [k for k, name in enumerate(rows[0]) if name not in ("setup_s", "solve_s")]
        return "\n".join(",".join(row[k] for k in keep) for row in rows).encode()
    return path.read_bytes()


def pvd_times(out: Path) -> dict:
    """The time each .pvd in `out` lists for each of its frames, by the frame's resolved path."""
    import xml.etree.ElementTree as ET
    times = {}
    for pvd in out.rglob("*.pvd"):
        for ds in ET.parse(pvd).getroot().iter("DataSet"):
            times[(pvd.parent / ds.get("file")).resolve()] = float(ds.get("timestep"))
    return times


def frame_record(path: Path, listed_time) -> dict:
    """What a .vtp frame holds, read by VTK: its time and a hash of each array's values."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    if reader.GetErrorCode() or reader.GetOutput() is None:
        return {"error": f"VTK could not read {path.name}"}
    data = reader.GetOutput()

    def digest(array) -> str:
        values = np.ascontiguousarray(vtk_to_numpy(array), dtype=np.float64)
        shape = f"{array.GetNumberOfTuples()}x{array.GetNumberOfComponents()}"
        return f"{shape} {hashlib.sha256(values.tobytes()).hexdigest()}"

    arrays = {"points": digest(data.GetPoints().GetData()) if data.GetPoints() else "none",
              "verts.connectivity": digest(data.GetVerts().GetConnectivityArray()),
              "verts.offsets": digest(data.GetVerts().GetOffsetsArray())}
    point_data = data.GetPointData()
    for k in range(point_data.GetNumberOfArrays()):
        arrays[f"point_data.{point_data.GetArrayName(k)}"] = digest(point_data.GetArray(k))
    time_array = data.GetFieldData().GetArray("TIME")
    time = time_array.GetValue(0) if time_array is not None else listed_time
    if time_array is not None and listed_time is not None and time != listed_time:
        time = f"TIME {time!r} but the .pvd lists {listed_time!r}"
    return {"time": time, "arrays": arrays}


@functools.cache
def schema_validator(path: Path):
    import jsonschema
    return jsonschema.Draft202012Validator(json.loads(path.read_text()))


def schema_errors(summary: dict) -> list[str]:
    """Where a summary breaks docs/summary.schema.json (Debian's python3-jsonschema), as messages."""
    validator = schema_validator(SCHEMA)

    def leaves(e):
        """For "not valid under any of the given schemas", the errors of the branch that got deepest into the value
        (an object's bad keys rather than "not a string"); else the error itself."""
        if not e.context:
            return [e]
        branches = {}
        for c in e.context:
            branches.setdefault(c.schema_path[0], []).append(c)
        nearest = max(branches.values(), key=lambda b: (max(len(c.absolute_path) for c in b),
                                                       any(c.validator != "type" for c in b)))
        return [leaf for c in nearest for leaf in leaves(c)]

    def message(e):
        if e.validator == "type" and "string" in e.validator_value and isinstance(e.instance, (int, float)):
            return f"{e.instance!r} is a number under a key that ends in no unit (docs/config-files.md#the-naming-rule)"
        return e.message

    return [f"/{'/'.join(map(str, e.absolute_path))}: {message(e)}"
            for error in validator.iter_errors(summary) for e in leaves(error)]


def run_case(build: Path, app: str, args: str) -> dict:
    with tempfile.TemporaryDirectory() as out:
        exe = build / "apps" / app / app
        env = dict(os.environ, OMP_NUM_THREADS="1")
        proc = subprocess.run([str(exe), *args.split(), "--out", out], env=env, capture_output=True, text=True)
        record = {"status": proc.returncode, "files": {}}
        listed = pvd_times(Path(out))
        for f in sorted(Path(out).rglob("*")):
            if not f.is_file():
                continue
            rel = str(f.relative_to(out))
            if f.name == "summary.json":
                summary = json.loads(f.read_text())
                # A run of several models (rotating --model both) has a summary in each model's folder.
                if rel == "summary.json":
                    record["summary"] = without_timings(summary)
                else:
                    record["files"][rel] = without_timings(summary)
                SCHEMA_ERRORS.extend(f"{app} {args}: {rel}{error}" for error in schema_errors(summary))
            elif f.suffix == ".vtp":
                record["files"][rel] = frame_record(f, listed.get(f.resolve()))
            else:
                record["files"][rel] = hashlib.sha256(comparable_bytes(f)).hexdigest()
        if "summary" not in record:
            record["stderr"] = proc.stderr[-2000:]
        return record


def differences(path: str, old, new) -> list[str]:
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new)):
            if k not in old or k not in new:
                out.append(f"{path}/{k}: {'added' if k in new else 'missing'}")
            else:
                out += differences(f"{path}/{k}", old[k], new[k])
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [d for i, (a, b) in enumerate(zip(old, new)) for d in differences(f"{path}[{i}]", a, b)]
    return [] if old == new else [f"{path}: {old!r} -> {new!r}"]


def main() -> int:
    if len(sys.argv) != 4 or sys.argv[1] not in ("record", "check"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    mode, build, record_file = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
    results = {}
    for name, (app, args) in CASES.items():
        results[name] = run_case(build, app, args)
        print(f"{name}: status {results[name]['status']}, {len(results[name]['files'])} files", flush=True)
    for e in SCHEMA_ERRORS:
        print("SCHEMA", e)
    schema = f"; {len(SCHEMA_ERRORS)} breaks of docs/summary.schema.json" if SCHEMA_ERRORS else ""
    if mode == "record":
        record_file.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
        print(f"recorded {len(results)} cases in {record_file}{schema}")
        return 0
    recorded = json.loads(record_file.read_text())
    diffs = differences("", recorded, results)
    for d in diffs:
        print("DIFF", d)
    print(f"{len(results)} cases: " + ("all bitwise the same" if not diffs else f"{len(diffs)} differences") + schema)
    return 1 if diffs or SCHEMA_ERRORS else 0


if __name__ == "__main__":
    sys.exit(main())
