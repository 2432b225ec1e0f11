#!/usr/bin/python3
"""SparseMPS and MPS-Basic (github.com/MPS-Basic/MPS-Basic, a public C++ MPS code) on MPS-Basic's own dam break, side
by side in one run: a column a = 0.25 m wide and 2a high at the left wall of a tank 1 m long with 0.6 m walls (its
input/dambreak), at the same spacing and with the same fluid particles. Times both codes in turn, one OpenMP thread
each, and writes fluid particle-steps per second, the wall time to the same simulated time and each surge front
against Martin & Moyce (1952) to bench/results/mps_basic.{csv,png} (docs/benchmarks.md).

  bench/mps_basic.py --mps-basic SRC [--ours build/release] [--across 10,32,70,224] [--end-time 0.4]
                     [--end-time-at 224:0.005] [--pairs 1]      (the defaults: the published run, about 20 minutes)

SRC is a checkout of MPS-Basic: built here from its sources (g++ -O3 -DNDEBUG -fopenmp, as its Release build; Debian's
Eigen 3.4, yaml-cpp and fast-cpp-csv-parser: apt-get install libeigen3-dev libyaml-cpp-dev libfccp-dev) with
bench/mps_basic_driver.cpp as its main, for measurement only; nothing of it is kept in this repository.

Each code runs its own model on the shared fluid particles: MPS-Basic its input/dambreak/settings.yml (2 wall and 2
dummy layers, the number-density source with relaxation 0.2, BiCGSTAB on every particle, a fixed dt kept at its
0.001 s per 0.025 m), SparseMPS the dam break's defaults (1 wall and 4 dummy layers, the mixed source, auto solver,
CFL 0.2). The front of both is the rightmost fluid particle with a fluid neighbour within 2.1 l0, plus l0/2, as the
dam break app measures it.
"""
import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import stamp  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
A, TANK, WALL_TOP, G = 0.25, 1.0, 0.6, 9.8


def build_mps_basic(src, out):
    """Compile MPS-Basic's sources (its main aside) with our driver, unless built since they last changed; returns the
    executable and the checkout's commit."""
    src = Path(src)
    if not (src / "src" / "simulation.cpp").exists():
        sys.exit(f"{src} is no MPS-Basic checkout (no src/simulation.cpp): give --mps-basic the repository's folder")
    missing = [p for p in ("/usr/include/eigen3/Eigen/Sparse", "/usr/include/yaml-cpp/yaml.h",
                           "/usr/include/libfccp/csv.h") if not os.path.exists(p)]
    if missing:
        sys.exit(f"missing {', '.join(missing)}: apt-get install libeigen3-dev libyaml-cpp-dev libfccp-dev")
    sources = sorted(str(p) for p in (src / "src").rglob("*.cpp") if p.name != "main.cpp")
    exe = Path(out) / "mps-basic"
    driver = ROOT / "bench" / "mps_basic_driver.cpp"
    commit = subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip() or "unknown"
    if exe.exists() and all(exe.stat().st_mtime > Path(p).stat().st_mtime for p in [*sources, driver]):
        return exe, commit
    cmd = ["g++", "-std=c++17", "-O3", "-DNDEBUG", "-fopenmp", "-w", f"-I{src / 'src'}", "-I/usr/include/eigen3",
           "-I/usr/include/libfccp", *sources, str(driver), "-o", str(exe),
           "-lyaml-cpp"]
    print("building MPS-Basic:", " ".join(cmd[:6]), "...", flush=True)
    subprocess.run(cmd, check=True)
    return exe, commit


def lattice(n):
    """The shared fluid (cell centres of the column, n across) and the tank's cells outside the water box, each with
    its layer: 0 the first row behind the wall line, 1 the next, ... (corners included)."""
    l0 = A / n
    fluid = [((i + 0.5) * l0, (j + 0.5) * l0) for i in range(n) for j in range(2 * n)]
    cells_x, cells_y = round(TANK / l0), round(WALL_TOP / l0)
    walls = []
    for i in range(-5, cells_x + 5):
        for j in range(-5, cells_y):
            layer = max(-i - 1, i - cells_x, -j - 1)
            if layer >= 0:
                walls.append(((i + 0.5) * l0, (j + 0.5) * l0, layer))
    return l0, fluid, walls


def write_mps_basic_case(folder, src, n, end_time, frames):
    """Its dam break's settings at spacing A/n: 2 wall and 2 dummy layers (its generator's), dt scaled with l0."""
    l0, fluid, walls = lattice(n)
    folder.mkdir(parents=True, exist_ok=True)
    rows = [(1, x, y) for x, y in fluid] + [(2 if layer < 2 else 3, x, y) for x, y, layer in walls if layer < 4]
    with open(folder / "input.prof", "w") as f:
        f.write(f"0\n{len(rows)}\n")
        for kind, x, y in rows:
            f.write(f"{kind} {x!r} {y!r} 0 0 0 0\n")
    settings = (Path(src) / "input" / "dambreak" / "settings.yml").read_text().splitlines()
    dt = 0.001 * l0 / 0.025  # its own dt per spacing: Courant 0.04 per m/s, within its CFL 0.3 to 7.5 m/s
    replace = {"particleDistance": repr(l0), "dt": repr(dt), "endTime": repr(end_time),
               "outputPeriod": repr(end_time / frames), "particlesPath": "./input.prof"}
    out = []
    for line in settings:
        key = line.split(":", 1)[0].strip()
        out.append(f"{key}: {replace[key]}" if key in replace and not line.lstrip().startswith("#") else line)
    (folder / "settings.yml").write_text("\n".join(out) + "\n")
    return l0, len(fluid), math.ceil(end_time / dt - 1e-9)


def write_our_case(path, n):
    """The same fluid, with our boundary: 1 wall layer and 4 dummy layers (mps::add_rectangle_walls(..., 1, 4))."""
    l0, fluid, walls = lattice(n)
    with open(path, "w") as f:
        f.write(f"# MPS-Basic's dam break at l0 = a/{n} (bench/mps_basic.py)\nx,y,kind\n")
        for x, y in fluid:
            f.write(f"{x!r},{y!r},fluid\n")
        for x, y, layer in walls:
            f.write(f"{x!r},{y!r},{'wall' if layer == 0 else 'dummy'}\n")
    return l0


def front_of(points, l0):
    """Rightmost fluid particle with a fluid neighbour within 2.1 l0, plus l0/2 (dambreak's surge_front)."""
    order = np.argsort(-points[:, 0])
    for i in order:
        d = np.hypot(points[:, 0] - points[i, 0], points[:, 1] - points[i, 1])
        if np.count_nonzero(d < 2.1 * l0) > 1:
            return points[i, 0] + 0.5 * l0
    return 0.0


def mps_basic_front(run_dir, l0):
    """(t, front) from its .prof frames (time, count, then type x y z u v w per particle)."""
    out = []
    for prof in sorted((run_dir / "prof").glob("output_*.prof")):
        with open(prof) as f:
            t = float(f.readline())
            f.readline()
            data = np.loadtxt(f, usecols=(0, 1, 2), ndmin=2)
        fluid = data[data[:, 0] == 1][:, 1:3]
        out.append((t, front_of(fluid, l0) if len(fluid) else 0.0))
    return out


def fronts_of(case, l0):
    """Both codes' fronts in T and x/a: ours from its front.csv, MPS-Basic's from its frames."""
    with open(case / "run_ours" / "front.csv") as f:
        r = list(csv.DictReader(f))
    theirs = mps_basic_front(case / "run_mps_basic", l0)
    scale = math.sqrt(2 * G / A)
    return (np.array([float(x["T"]) for x in r]), np.array([float(x["x_over_a"]) for x in r]),
            np.array([t for t, _ in theirs]) * scale, np.array([x for _, x in theirs]) / A)


def mm_data():
    series = []
    for name in ("mm_data_1.txt", "mm_data_2.txt"):
        series.append(np.loadtxt(ROOT / "data" / "dambreak" / name, ndmin=2))
    return series


def front_error(T, Z, t_max):
    """Mean and largest relative error of the front Z(T) against both Martin & Moyce series up to T = t_max."""
    errors = []
    for data in mm_data():
        for t_exp, z_exp in data:
            if t_exp <= t_max and T[0] <= t_exp <= T[-1]:
                errors.append((np.interp(t_exp, T, Z) - z_exp) / z_exp)
    return float(np.mean(errors)), float(max(errors, key=abs))


def timed(cmd, log, env):
    start = time.perf_counter()
    with open(log, "w") as f:
        proc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env=env)
    return proc.returncode, time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mps-basic", required=True, help="a checkout of MPS-Basic's repository")
    ap.add_argument("--ours", default="build/release", help="our build folder (default build/release)")
    ap.add_argument("--across", default="10,32,70,224",
                    help="particles across the column's width a (2n^2 fluid: 10 is MPS-Basic's own 0.025 m spacing "
                         "with 200 fluid, 70 about 1e4, 224 about 1e5)")
    ap.add_argument("--end-time", type=float, default=0.4, help="simulated time [s] (0.4: T = t sqrt(2g/a) = 3.5)")
    ap.add_argument("--end-time-at", default="224:0.005",
                    help="n:t,... a shorter simulated time for some sizes (the first steps' speed only; MPS-Basic "
                         "would take hours at 1e5 to 0.4 s); '' for none")
    ap.add_argument("--pairs", type=int, default=1, help="runs of each code per size, in turn")
    ap.add_argument("--work", default="/tmp/mps_basic_bench", help="scratch folder (builds, cases, runs)")
    ap.add_argument("--csv", default=str(ROOT / "bench" / "results" / "mps_basic.csv"))
    ap.add_argument("--png", default=str(ROOT / "bench" / "results" / "mps_basic.png"))
    ap.add_argument("--replot", action="store_true", help="redraw the chart from --csv and the runs in --work")
    a = ap.parse_args()
    if a.replot:
        with open(a.csv) as f:
            rows = [{k: (v if k.endswith("commit") else float(v) if v else v) for k, v in r.items()}
                    for r in csv.DictReader(f)]
        fronts = {int(r["across"]): fronts_of(Path(a.work) / f"case_{int(r['across'])}", r["l0_m"]) for r in rows}
        plot(rows, fronts, a)
        return

    ours = Path(a.ours) / "apps" / "dambreak" / "dambreak"
    if not ours.exists():
        sys.exit(f"{ours} not found: build SparseMPS first (or give --ours BUILD)")
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    exe, their_commit = build_mps_basic(a.mps_basic, work)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    end_at = {int(k): float(v) for k, v in (kv.split(":") for kv in a.end_time_at.split(",") if kv)}
    scale = math.sqrt(2 * G / A)  # T = t sqrt(2g/a)
    rows, fronts = [], {}
    print(stamp.machine(), "| SparseMPS", stamp.commit(), "| MPS-Basic", their_commit, flush=True)
    for n in (int(s) for s in a.across.split(",")):
        end = end_at.get(n, a.end_time)
        case = work / f"case_{n}"
        l0, fluid, their_steps = write_mps_basic_case(case / "mps_basic", a.mps_basic, n, end, 40)
        write_our_case(case / "ours.csv", n)
        walls = {"ours": [], "mps_basic": []}
        for k in range(a.pairs):
            order = ["mps_basic", "ours"] if k % 2 == 0 else ["ours", "mps_basic"]
            for code in order:
                run = case / f"run_{code}"
                shutil.rmtree(run, ignore_errors=True)
                if code == "ours":
                    cmd = [str(ours), "--particles", str(case / "ours.csv"), "--end-time", repr(end), "--frames", "0",
                           "--out", str(run)]
                else:
                    cmd = [str(exe), str(case / "mps_basic" / "settings.yml"), str(run)]
                run.mkdir(parents=True)
                rc, wall = timed(cmd, case / f"{code}.log", env)
                if rc != 0:
                    sys.exit(f"{code} at n = {n} failed (exit {rc}); its output is in {case / (code + '.log')}")
                walls[code].append(wall)
        summary = json.loads((case / "run_ours" / "summary.json").read_text())
        our_steps, timings = summary["steps"], summary["timings"]
        fronts[n] = ours_T, ours_Z, their_T, their_Z = fronts_of(case, l0)
        # Up to T = 2.8 the front stays clear of the far wall (x = 4a), where it climbs.
        t_max = min(2.8, end * scale)
        row = {"across": n, "l0_m": l0, "fluid": fluid, "end_time_s": end,
               "ours_steps": our_steps, "mps_basic_steps": their_steps,
               "ours_wall_s": min(walls["ours"]), "mps_basic_wall_s": min(walls["mps_basic"]),
               "ours_solver_setup_s": timings["solver_setup_s"], "ours_solve_s": timings["solve_s"],
               "ours_other_phases_s": timings["total_s"] - timings["solver_setup_s"] - timings["solve_s"],
               "sparsemps_commit": stamp.commit(), "mps_basic_commit": their_commit}
        row["ours_particle_steps_per_s"] = fluid * our_steps / row["ours_wall_s"]
        row["mps_basic_particle_steps_per_s"] = fluid * their_steps / row["mps_basic_wall_s"]
        row["particle_steps_ratio"] = row["ours_particle_steps_per_s"] / row["mps_basic_particle_steps_per_s"]
        row["wall_time_ratio"] = row["mps_basic_wall_s"] / row["ours_wall_s"]
        if t_max > 1.0:
            row["ours_front_mean_error"], row["ours_front_max_error"] = front_error(ours_T, ours_Z, t_max)
            row["mps_basic_front_mean_error"], row["mps_basic_front_max_error"] = front_error(their_T, their_Z, t_max)
        rows.append(row)
        print(json.dumps(row), flush=True)

    keys = list(dict.fromkeys(k for r in rows for k in r))
    Path(a.csv).parent.mkdir(parents=True, exist_ok=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    plot(rows, fronts, a)
    print("wrote", a.csv, "and", a.png)


def plot(rows, fronts, a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    for data, label, marker in zip(mm_data(), ("Martin & Moyce, a = 2.25 in", "Martin & Moyce, a = 1.125 in"),
                                   ("o", "s")):
        left.plot(data[:, 0], data[:, 1], marker, mfc="none", color="k", label=label)
    colours = plt.cm.viridis(np.linspace(0, 0.8, len(fronts)))
    for (n, (oT, oZ, tT, tZ)), c in zip(sorted(fronts.items()), colours):
        if oT[-1] < 1.0:
            continue  # a run cut short has no front to compare
        fluid = 2 * n * n
        left.plot(oT, oZ, "-", color=c, label=f"SparseMPS, {fluid} fluid")
        left.plot(tT, tZ, "--", color=c, label=f"MPS-Basic, {fluid} fluid")
    left.set_xlim(0, 3.5)
    left.set_ylim(1, 4.2)
    left.set_xlabel("T = t sqrt(2g/a)")
    left.set_ylabel("front x / a")
    left.set_title("surge front (far wall at x/a = 4)")
    left.legend(fontsize=7)
    # Runs cut short (--end-time-at) cover the collapse's start only: drawn hollow, not joined to the whole runs.
    whole = [r for r in rows if r["end_time_s"] == a.end_time]
    short = [r for r in rows if r["end_time_s"] != a.end_time]
    for subset, style, fill, tag in ((whole, "-", None, f"to {a.end_time:g} s"), (short, "", "none", "first steps")):
        if not subset:
            continue
        fluid = [r["fluid"] for r in subset]
        right.loglog(fluid, [r["ours_particle_steps_per_s"] for r in subset], "o" + style, color="C0", mfc=fill,
                     label=f"SparseMPS, {tag}")
        right.loglog(fluid, [r["mps_basic_particle_steps_per_s"] for r in subset], "s" + style.replace("-", "--"),
                     color="C1", mfc=fill, label=f"MPS-Basic, {tag}")
    for r in rows:
        note = f"{r['particle_steps_ratio']:.1f}x"
        if r["end_time_s"] != a.end_time:
            note += f" (to {r['end_time_s']:g} s)"
        right.annotate(note, (r["fluid"], r["ours_particle_steps_per_s"]), textcoords="offset points",
                       xytext=(-20, 8), fontsize=8)
    right.set_xlabel("fluid particles")
    right.set_ylabel("fluid particle-steps per second (one thread)")
    right.set_title("throughput: fluid particles x steps / each process's wall time")
    right.legend()
    right.set_xlim(100, 4e5)
    fig.suptitle(f"MPS-Basic's dam break, both codes in one run: {stamp.machine()}\nSparseMPS "
                 f"{rows[0]['sparsemps_commit']}, MPS-Basic {rows[0]['mps_basic_commit']}; bench/mps_basic.py "
                 f"--across {a.across}", fontsize=9)
    fig.tight_layout()
    fig.savefig(a.png, dpi=110)


if __name__ == "__main__":
    main()
