#!/usr/bin/python3
"""Scenes from particle files (dambreak --particles and --write-particles, docs/particle-files.md):

1. The classic column written out and run from its file gives bitwise the built-in run: the same bytes in every file
   it writes (frames, front, level, pressure, solves.csv less its timings) and the same summary less its timings,
   its run record and the file's path.
2. The obstacle example (scripts/obstacle_tank.py: a block on the floor in the surge's path) runs as a new scene:
   its tank and water found from the file, no experiment compared, the block standing still, no fluid ever inside
   it, and the water's impact pressing on its upstream face. Without the block the surge is past its far side by the
   end of the run, so each of these would fail if the file's geometry were not read.
3. A frame made a particle file (scripts/frame_to_csv.py) holds the frame's values bit for bit, and a run starts
   from it: the first frame as the classic column, a later one, moving, as a new scene. The later frame read as it
   is (--particles FRAME.vtp) and as VTK's own writer writes it again (zlib, UInt32 headers) runs bitwise as from
   its CSV file.
4. A broken file, a file with no tank and a --dx that is not the file's spacing end with exit 1 and a message
   naming the cause.
5. In 3-D (--dim 3): SPHERIC Test 2 written out and run from its file gives bitwise the built-in run, as in 1; the
   obstacle example's 3-D pillar (scripts/obstacle_tank.py --dim 3) runs as a new scene with 1's checks, the water
   flowing round and over the pillar; a 2-D file with --dim 3 and a 3-D file without it are refused.

  tests/particle_files.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

SOURCE = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(SOURCE / "scripts"))
from compare_results import comparable_bytes, without_timings  # noqa: E402


def run(build, args, out=None):
    cmd = [str(Path(build) / "apps" / "dambreak" / "dambreak"), *args] + (["--out", str(out)] if out else [])
    return subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)


def outputs(out):
    files = {str(f.relative_to(out)): comparable_bytes(f) for f in sorted(Path(out).rglob("*"))
             if f.is_file() and f.name not in ("summary.json", "config.toml")}
    summary = json.loads((Path(out) / "summary.json").read_text())
    summary.pop("run")
    summary["parameters"].pop("particle_file", None)
    return files, without_timings(summary)


def frames(out, dim=2):
    """Each frame of a run as (time, dict of arrays), through VTK's own reader."""
    result = []
    for f in sorted((Path(out) / "frames").glob("*.vtp")):
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(f))
        reader.Update()
        data = reader.GetOutput()
        arrays = {name: vtk_to_numpy(data.GetPointData().GetArray(name)) for name in ("kind", "group", "pressure", "id")}
        arrays["xy"] = vtk_to_numpy(data.GetPoints().GetData())[:, :dim]
        result.append((float(vtk_to_numpy(data.GetFieldData().GetArray("TIME"))[0]), arrays))
    return result


def round_trip(build, tmp, failures, dim=2):
    scene = ["--column", "classic"] if dim == 2 else ["--dim", "3", "--dx", "0.08"]
    name, end, ppe = ("classic", "0.05", "20") if dim == 2 else ("spheric2", "0.1", "5")
    written = run(build, [*scene, "--write-particles", str(tmp / f"{name}.csv")])
    if written.returncode != 0:
        failures.append(f"--write-particles: exit {written.returncode}: {written.stderr[-300:]}")
        return
    dx = written.stdout.split("--dx")[-1].split()[0]
    common = ["--end-time", end, "--frames", "3", "--export-ppe", ppe]
    built_in = run(build, [*scene, *common], tmp / f"built-in{dim}")
    from_file = run(build, [*([] if dim == 2 else ["--dim", "3"]), "--particles", str(tmp / f"{name}.csv"), "--dx", dx, *common],
                    tmp / f"from-file{dim}")
    if built_in.returncode != from_file.returncode:
        failures.append(f"exit {built_in.returncode} built in, {from_file.returncode} from the file: "
                        f"{from_file.stderr[-300:]}")
        return
    files, summary = outputs(tmp / f"built-in{dim}")
    files2, summary2 = outputs(tmp / f"from-file{dim}")
    differ = sorted(k for k in set(files) | set(files2) if files.get(k) != files2.get(k))
    if differ:
        failures.append(f"round trip: files differ: {differ}")
    if summary != summary2:
        keys = sorted(k for k in set(summary) | set(summary2) if summary.get(k) != summary2.get(k))
        failures.append(f"round trip: the summaries differ in {keys}")
    config = (tmp / f"from-file{dim}" / "config.toml").read_text()
    if f'particles = "../{name}.csv"' not in config.splitlines():  # relative to the file's folder
        failures.append("config.toml does not record the particle file")
    if summary2["parameters"]["column"] != name:
        failures.append(f"round trip: ran as {summary2['parameters']['column']}, not {name}")
    print(f"round trip, {dim}-D: {len(files)} files and the summary bitwise the same ({summary['steps']} steps, "
          f"column {summary2['parameters']['column']})")


def block_in_frames(name, shown, count, face_x, inside_outline, failures):
    """A block's (group 1) particles through a run's frames: they must number `count` and stand still, no fluid may lie
    inside its outline (inside_outline(fluid positions) -> mask) and its upstream face (x = face_x) must carry an
    impact above 0.3 rho g H of the classic column. Returns (moved, fluid inside, peak pressure)."""
    first, peak, inside, moved = None, 0.0, 0, 0.0
    for _, f in shown:
        block = f["group"] == 1
        r = f["xy"][block][np.argsort(f["id"][block])]  # the frames hold the particles in the step's order
        if first is None:
            first = r
        elif len(r) == len(first):
            moved = max(moved, np.abs(r - first).max())
        inside += int(inside_outline(f["xy"][f["kind"] == 0]).sum())
        face = block & (f["kind"] == 1) & (np.abs(f["xy"][:, 0] - face_x) < 1e-9)
        peak = max(peak, f["pressure"][face].max(initial=0.0))
    rho_g_h = 1000 * 9.81 * 2 * 0.146
    if first is None or len(first) != count:
        failures.append(f"{name}: {0 if first is None else len(first)} block particles in the frames, not {count}")
    if moved != 0.0:
        failures.append(f"{name}: the block moved by {moved} m")
    if inside:
        failures.append(f"{name}: fluid inside the block ({inside} particle-frames)")
    if not peak > 0.3 * rho_g_h:
        failures.append(f"{name}: the block's upstream face peaked at {peak:.0f} Pa, below 0.3 rho g H: no impact")
    return moved, inside, peak


def run_obstacle_example(build, tmp, name, dim, run_args, failures):
    """scripts/obstacle_tank.py's file in `dim` dimensions, run: (its summary or None if the run failed, its folder)."""
    csv, out = tmp / f"{name}.csv", tmp / name
    subprocess.run(["/usr/bin/python3", str(SOURCE / "scripts" / "obstacle_tank.py"), str(csv), "--dim", str(dim)],
                   check=True, capture_output=True)
    proc = run(build, [*(["--dim", "3"] if dim == 3 else []), "--particles", str(csv), *run_args], out)
    if proc.returncode != 0:
        failures.append(f"{name}: exit {proc.returncode}: {proc.stderr[-300:]}")
        return None, out
    return json.loads((out / "summary.json").read_text()), out


def obstacle(build, tmp, failures):
    summary, out = run_obstacle_example(build, tmp, "obstacle", 2, ["--end-time", "0.15", "--frames", "15"], failures)
    if summary is None:
        return
    a = 0.146
    l0 = a / 20
    parameters = summary["parameters"]
    found = {k: parameters[k] for k in ("column", "tank_length_m", "tank_height_m", "column_width_m",
                                        "column_height_m")}
    expected = {"column": "file", "tank_length_m": 4 * a, "tank_height_m": 3 * a, "column_width_m": a,
                "column_height_m": 2 * a}
    if any(found[k] != v if isinstance(v, str) else abs(found[k] - v) > 1e-12 for k, v in expected.items()):
        failures.append(f"obstacle: the scene found {found}, expected {expected}")
    if summary["status"] != "completed" or "martin_moyce_1_front_max_error" in summary["checks"]:
        failures.append(f"obstacle: status {summary['status']}, checks {summary['checks']}: an experiment compared")
    # The block: x in [2a, 2.5a], 0.5a high; its faces' particles sit l0/2 inside its outline.
    x0, x1, top, h = 2 * a, 2.5 * a, 0.5 * a, 0.5 * l0
    shown = frames(out)
    moved, inside, peak = block_in_frames(
        "obstacle", shown, 100, x0 + h,
        lambda r: (r[:, 0] > x0 + h) & (r[:, 0] < x1 - h) & (r[:, 1] < top - h), failures)
    print(f"obstacle: the block moved {moved:.3g} m; fluid inside it {inside} times; peak pressure on its upstream face "
          f"{peak:.0f} Pa = {peak / (1000 * 9.81 * 2 * a):.2f} rho g H over {len(shown)} frames")
    front = np.loadtxt(out / "front.csv", delimiter=",", skiprows=1)
    if not front[-1, 1] > 1.9:
        failures.append(f"obstacle: the surge front ended at {front[-1, 1]:.3f} a, short of the block at 2 a")


def obstacle_3d(build, tmp, failures):
    summary, out = run_obstacle_example(build, tmp, "pillar", 3, ["--end-time", "0.2", "--frames", "20"], failures)
    if summary is None:
        return
    a = 0.146
    l0 = a / 10
    # The pillar: x in [2a, 2.5a], y in [0.2a, 0.8a] (whole cells: 2 to 8 of 10), 0.5a high.
    x0, x1, y0, y1, top = 2 * a, 2.5 * a, 0.2 * a, 0.8 * a, 0.5 * a
    parameters = summary["parameters"]
    expected = {"tank_m": [4 * a, a, 3 * a], "column_m": [0, a, 2 * a], "obstacle_boxes_m": [[x0, x1, y0, y1, 0, top]]}
    found = {k: parameters.get(k) for k in expected}
    close = all(found[k] is not None and np.allclose(np.array(found[k], dtype=float), np.array(v), rtol=0, atol=1e-12)
                for k, v in expected.items())
    if parameters["column"] != "file" or not close:
        failures.append(f"pillar: the scene found {parameters['column']}, {found}, expected {expected}")
    if summary["status"] != "completed" or "p1_arrival_s" in summary["checks"]:
        failures.append(f"pillar: status {summary['status']}, checks {summary['checks']}: an experiment compared")
    h = 0.5 * l0
    shown = frames(out, 3)
    moved, inside, peak = block_in_frames(
        "pillar", shown, 5 * 6 * 5, x0 + h,
        lambda r: (r[:, 0] > x0 + h) & (r[:, 0] < x1 - h) & (r[:, 1] > y0 + h) & (r[:, 1] < y1 - h) & (r[:, 2] < top - h),
        failures)
    # Round the pillar: fluid level with it, in the gaps between it and the side walls, below its top; and past it.
    beside = max(int(((x > x0) & (x < x1) & ((y < y0) | (y > y1)) & (z < top)).sum())
                 for x, y, z in (f["xy"][f["kind"] == 0].T for _, f in shown))
    beyond = max(int((f["xy"][f["kind"] == 0, 0] > x1).sum()) for _, f in shown)
    print(f"pillar (3-D): moved {moved:.3g} m; fluid inside it {inside} times, beside it up to {beside}, past it up to "
          f"{beyond}; its upstream face peaked at {peak:.0f} Pa = {peak / (1000 * 9.81 * 2 * a):.2f} rho g H over "
          f"{len(shown)} frames")
    if not (beside > 0 and beyond > 0):
        failures.append(f"pillar: the water did not flow round it ({beside} beside it, {beyond} past it)")
    cases = [(["--dim", "3", "--particles", str(tmp / "classic.csv")], "the header has no column 'z'"),
             (["--particles", str(tmp / "pillar.csv")], "a 3-D particle file; this scene is 2-D")]
    for args, message in cases:
        proc = run(build, args, tmp / "refused")
        if proc.returncode == 0 or message not in proc.stderr:
            failures.append(f"{' '.join(args)}: exit {proc.returncode}, stderr {proc.stderr[-300:]!r}, "
                            f"expected {message!r}")


def from_frames(build, tmp, failures):
    for number, column in ((0, "classic"), (3, "file")):
        frame = tmp / "built-in2" / "frames" / f"dambreak_{number:04d}.vtp"
        csv = tmp / f"frame{number}.csv"
        subprocess.run(["/usr/bin/python3", str(SOURCE / "scripts" / "frame_to_csv.py"), str(frame), str(csv)],
                       check=True, capture_output=True)
        table = np.genfromtxt(csv, delimiter=",", skip_header=2, dtype=None, encoding=None)
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(frame))
        reader.Update()
        data = reader.GetOutput()
        xy = vtk_to_numpy(data.GetPoints().GetData())
        uv = vtk_to_numpy(data.GetPointData().GetArray("velocity"))
        p = vtk_to_numpy(data.GetPointData().GetArray("pressure"))
        columns = [np.array([row[k] for row in table], dtype=float) for k in (0, 1, 3, 4, 5)]
        if not all(np.array_equal(c, v) for c, v in zip(columns, (xy[:, 0], xy[:, 1], uv[:, 0], uv[:, 1], p))):
            failures.append(f"{csv.name}: the values differ from the frame's")
        out = tmp / f"from-frame{number}"
        proc = run(build, ["--particles", str(csv), "--end-time", "0.01", "--frames", "0", "--export-ppe", "1"], out)
        found = json.loads((out / "summary.json").read_text())["parameters"]["column"] if proc.returncode in (0, 2) \
            else f"exit {proc.returncode}: {proc.stderr[-300:]}"
        if found != column:
            failures.append(f"{csv.name}: ran as {found}, expected {column}")
    frame = tmp / "built-in2" / "frames" / "dambreak_0003.vtp"
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(frame))
    writer = vtk.vtkXMLPolyDataWriter()  # VTK's own layout: 32-bit headers, its block size
    writer.SetInputConnection(reader.GetOutputPort())
    writer.SetFileName(str(tmp / "vtk-written.vtp"))
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetCompressorTypeToZLib()
    writer.SetHeaderTypeToUInt32()
    writer.Write()
    compared = ("front.csv", "ppe/step_000001.mtx", "ppe/step_000001_rhs.mtx")  # the PPE: 17 digits

    def content(out):  # the PPE's header names the particle file: left out
        return [b"".join(l for l in (out / name).read_bytes().splitlines(True) if not l.startswith(b"% scene:"))
                for name in compared]
    expected = content(tmp / "from-frame3")
    for source in (frame, tmp / "vtk-written.vtp"):
        out = tmp / f"from-{source.stem}"
        proc = run(build, ["--particles", str(source), "--end-time", "0.01", "--frames", "0", "--export-ppe", "1"], out)
        if proc.returncode not in (0, 2) or content(out) != expected:
            failures.append(f"--particles {source.name}: exit {proc.returncode}, not the run from its CSV file: "
                            f"{proc.stderr[-300:]}")
    print("frames: made particle files bit for bit, the first run as the classic column, a later one as a new scene, "
          "also read as .vtp (ours and VTK's)")


def refusals(build, tmp, failures):
    (tmp / "bad.csv").write_text("# a tank\nx,y,kind\n0.1,0.1,fluid\n0.2,0.1,water\n")
    (tmp / "no-tank.csv").write_text("x,y,kind\n" + "".join(f"{0.01 * i},{0.01 * j},fluid\n" for i in range(8)
                                                            for j in range(8)))
    # The classic column's file with one particle changed, or every position scaled.
    lines = (tmp / "classic.csv").read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")

    def edited(name, kind, column, value, scale=1.0):
        rows, done = [], False
        for line in lines[header + 1:]:
            row = dict(zip(names, line.split(",")))
            if not done and row["kind"] == kind and column:
                row[column], done = value, True
            row["x"], row["y"] = repr(float(row["x"]) * scale), repr(float(row["y"]) * scale)
            rows.append(",".join(row[n] for n in names))
        (tmp / name).write_text("\n".join(lines[:header + 1] + rows) + "\n")
        return str(tmp / name)

    cases = [(["--particles", str(tmp / "bad.csv")], "bad.csv:4: kind 'water' is not fluid, wall or dummy"),
             (["--particles", str(tmp / "no-tank.csv")], "no wall particles: a dam break needs a tank"),
             (["--particles", str(tmp / "classic.csv"), "--dx", "0.01"], "give the spacing the file was made with"),
             (["--particles", str(tmp / "missing.csv")], "missing.csv"),
             (["--particles", ""], "--particles: the path is empty"),
             (["--particles", str(tmp / "classic.csv"), "--column", "seed"], "--column seed and --particles"),
             (["--particles", edited("far-wall.csv", "wall", "x", "1e300")], "a wall particle lies far from the others"),
             (["--particles", edited("fast.csv", "fluid", "u", "1e10")], "moves at 1e+10 m/s, more than 10 times"),
             (["--particles", edited("pressed.csv", "fluid", "p", "1e300")], "holds the pressure 1e+300 Pa"),
             (["--particles", edited("tiny.csv", "fluid", None, None, 1e-9)], "steps, more than the 1e+08"),
             (["--column", "classic", "--dx", "1"], "at most 0.0365 m")]
    for args, message in cases:
        proc = run(build, args, tmp / "refused")
        if proc.returncode == 0 or message not in proc.stderr:
            failures.append(f"{' '.join(args)}: exit {proc.returncode}, stderr {proc.stderr[-300:]!r}, "
                            f"expected {message!r}")
    # An output path that is not a file is refused and left as it was (a rename once replaced /dev/full).
    os.mkfifo(tmp / "a-fifo")
    for target in (tmp / "a-fifo", tmp):
        proc = run(build, ["--column", "classic", "--dx", "0.0146", "--write-particles", str(target)])
        if proc.returncode == 0 or "not a regular file" not in proc.stderr:
            failures.append(f"--write-particles {target}: exit {proc.returncode}, stderr {proc.stderr[-300:]!r}")
    if not (tmp / "a-fifo").is_fifo():
        failures.append("--write-particles replaced a FIFO")
    print(f"refusals: {len(cases) + 2} bad inputs refused with their cause")


def main():
    build = sys.argv[1]
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        round_trip(build, Path(tmp), failures)
        round_trip(build, Path(tmp), failures, dim=3)
        obstacle(build, Path(tmp), failures)
        obstacle_3d(build, Path(tmp), failures)
        from_frames(build, Path(tmp), failures)
        refusals(build, Path(tmp), failures)
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
