#!/usr/bin/python3
"""Where the classic column's front stops converging (docs/dambreak.md, "The classic column's front"): the front as the
app reads it (the leading fluid particle, front.csv) beside the front taken where the water is 0.02, 0.05 and 0.1 a
deep, at a/20, a/40 and a/80 with the defaults (`hs+ds`, no collisions, to T = 3.5). Writes
bench/results/dambreak_front_depth.csv (every frame), dambreak_front_depth_summary.csv (per definition: the developed speed fitted over T in [1.5, 3.5] at each
spacing, and the largest difference between a/40 and a/80 over T in [0.5, 3.5]) and a chart.

  bench/dambreak_front_depth.py BUILD_DIR [--runs DIR] [--results DIR] [--spacings 20,40,80] [--jobs 2]

A frame every 0.05 in T; a/80 takes about 5 minutes on one thread. A run already in --runs is read, not rerun.
The depth is the fluid's area per unit length, each particle's l0^2 spread by a hat 0.2 a wide; the front at a depth
is the last x where that reaches it, interpolated between points 0.002 a apart.
"""
import math
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor

import matplotlib
import numpy as np

from dambreak_impact import fluid_frames, read_columns
from dambreak_pressure import seed_bench_setup, write_rows

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

A, G = 0.146, 9.81  # the classic column's width [m]
END_T, FRAME_T = 3.5, 0.05
DEPTHS = (0.02, 0.05, 0.1)  # [a]
HAT, STEP = 0.1 * A, 0.002 * A  # the hat's half-width and the profile's spacing
SPEED_FIT, COMPARED = (1.5, 3.5), (0.5, 3.5)


def run(exe, out, across):
    """The run at a/across (the double 0.146 / across, as the app's default a/40 is) with the defaults."""
    if not (out / "summary.json").exists():
        out.mkdir(parents=True, exist_ok=True)
        cmd = [str(exe), "--column", "classic", "--dx", repr(A / across), "--frames", str(round(END_T / FRAME_T)),
               "--out", str(out)]
        done = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
        if done.returncode not in (0, 2):  # 2: completed, a check failed (a/20's speed does)
            raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return out


def front_at_depth(x, l0, depth):
    """The last x [a] where the fluid's area per unit length reaches `depth` [a]."""
    grid = np.arange(0.0, 8 * A + 2 * HAT, STEP)
    counts = np.histogram(x, np.append(grid, grid[-1] + STEP) - STEP / 2)[0]
    offsets = np.arange(-HAT, HAT + STEP / 2, STEP)
    hat = np.clip(1 - np.abs(offsets) / HAT, 0, None)
    profile = np.convolve(counts, hat / hat.sum(), mode="same") * l0 * l0 / STEP / A
    deep = np.nonzero(profile >= depth)[0]
    if len(deep) == 0 or deep[-1] + 1 >= len(grid):
        return math.nan
    k = deep[-1]
    return (grid[k] + (profile[k] - depth) / (profile[k] - profile[k + 1]) * STEP) / A


def fronts(out, l0):
    """Rows of T, the app's front and the fronts at DEPTHS, one per frame."""
    app = read_columns(out / "front.csv")
    rows = []
    for T, positions in fluid_frames(out, 0.0, scale=math.sqrt(2 * G / A)):
        row = {"T": T, "tip": float(np.interp(T, app["T"], app["x_over_a"]))}
        for depth in DEPTHS:
            row[f"depth_{depth}a"] = front_at_depth(positions[:, 0], l0, depth)
        rows.append(row)
    return rows


def speed(rows, name):
    T = np.array([r["T"] for r in rows])
    x = np.array([r[name] for r in rows])
    inside = (T >= SPEED_FIT[0]) & (T <= SPEED_FIT[1])
    return np.polyfit(T[inside], x[inside], 1)[0]


def relative_difference(finer, coarser, name):
    """(T, (coarser - finer) / finer) at the finer run's frames, the coarser run's front interpolated to their T (a
    frame is written at the first step past its time, which differs between spacings)."""
    T = np.array([r["T"] for r in finer])
    coarse = np.interp(T, [r["T"] for r in coarser], [r[name] for r in coarser])
    return T, coarse / np.array([r[name] for r in finer]) - 1


def largest_difference(finer, coarser, name):
    """The largest |coarser - finer| / finer over COMPARED, with its T."""
    T, difference = relative_difference(finer, coarser, name)
    inside = np.nonzero((T >= COMPARED[0]) & (T <= COMPARED[1]))[0]
    k = inside[np.argmax(np.abs(difference[inside]))]
    return abs(difference[k]), T[k]


def main():
    args, results, runs, exe, spacings = seed_bench_setup("runs/dambreak-front-depth", "20,40,80")
    if sorted(spacings)[-2:] != [40, 80]:
        raise SystemExit("--spacings must end with 40 and 80 (a/N): the two compared")
    with ThreadPoolExecutor(args.jobs) as pool:
        outs = dict(zip(spacings, pool.map(lambda n: run(exe, runs / f"a{n}", n), spacings)))
    series = {n: fronts(outs[n], A / n) for n in spacings}
    names = ["tip"] + [f"depth_{d}a" for d in DEPTHS]
    write_rows(results / "dambreak_front_depth.csv",
               [{"spacing": f"a/{n}", **{k: f"{v:.4f}" for k, v in r.items()}} for n in spacings for r in series[n]])
    summary = []
    for name in names:
        difference, at = largest_difference(series[80], series[40], name)
        summary.append({"front": name, **{f"speed_a{n}": f"{speed(series[n], name):.3f}" for n in spacings},
                        "largest_difference_a40_a80": f"{difference:.4f}", "at_T": f"{at:.2f}"})
        print(summary[-1])
    write_rows(results / "dambreak_front_depth_summary.csv", summary)

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for n, style in zip(sorted(spacings), (":", "--", "-")):
        T = [r["T"] for r in series[n]]
        left.plot(T, [r["tip"] for r in series[n]], "k" + style, label=f"leading particle, a/{n}")
        left.plot(T, [r["depth_0.05a"] for r in series[n]], "C0" + style, label=f"0.05 a deep, a/{n}")
    left.set(xlabel="T = t sqrt(2g/a)", ylabel="front x / a", title="classic column, the defaults (hs+ds)")
    left.legend(fontsize=8)
    for k, name in enumerate(names):
        T, difference = relative_difference(series[80], series[40], name)
        right.plot(T, 100 * difference, f"C{k}", label=name.replace("_", " ").replace("tip", "leading particle"))
    right.axhline(-1, color="grey", lw=0.5)
    right.axhline(1, color="grey", lw=0.5)
    right.set(xlabel="T", ylabel="(a/40 - a/80) / a/80 [%]", title="the front at a/40 against a/80", xlim=COMPARED)
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(results / "dambreak_front_depth.png", dpi=110)


if __name__ == "__main__":
    main()
