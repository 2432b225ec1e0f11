#!/usr/bin/python3
"""One thread against two, with OpenMP's active (spinning) and passive wait policies, on an idle machine and with one
other busy process (`yes > /dev/null`) on it: a small scene (the classic dam break, 800 fluid particles, its default
run: below the library's threshold for a second thread, mps/core/threads.hpp), a middle one (the seed's column at its
spacing H/50, 5,000 fluid, to t sqrt(g/H) = 1) and a large one (bench_scaling's body-force channel at 1e5 particles,
4 steps after 2). The apps run passive unless told otherwise (apps/common/openmp_wait.hpp); bench_scaling takes the
environment as it is.

  bench/thread_wait.py BUILD_DIR [--results bench/results] [--repeats 3] [--plot-only]

Writes thread_wait.csv (one row per run: wall seconds of the whole process) and thread_wait.png (median wall time
over one thread's, per scene, load and setting). Needs an otherwise idle 2-core machine.
"""
import argparse
import csv
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

SETTINGS = {"1 thread": {"OMP_NUM_THREADS": "1"},
            "2 threads, active": {"OMP_NUM_THREADS": "2", "OMP_WAIT_POLICY": "active"},
            "2 threads, passive": {"OMP_NUM_THREADS": "2", "OMP_WAIT_POLICY": "passive"}}


def scenes(build, tmp):
    return {"dam break, 800 fluid": [str(Path(build) / "apps" / "dambreak" / "dambreak"), "--column", "classic",
                                     "--out", str(Path(tmp) / "dambreak")],
            "dam break, seed column H/50": [str(Path(build) / "apps" / "dambreak" / "dambreak"), "--column", "seed",
                                            "--dx", "0.02", "--end-time", "0.32", "--frames", "0",
                                            "--out", str(Path(tmp) / "seed")],
            "channel, 1e5 particles": [str(Path(build) / "bench" / "bench_scaling"), "--sizes", "1e5", "--solvers",
                                       "auto", "--cold", "", "--warmup", "2", "--steps", "4", "--out",
                                       str(Path(tmp) / "scaling.csv")]}


def timed(cmd, env):
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode not in (0, 2):  # 2: the dam break's front check, which its default run does not pass
        raise RuntimeError(f"{cmd[0]} failed ({proc.returncode}): {proc.stderr[-500:]}")
    return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    results = Path(a.results)
    results.mkdir(parents=True, exist_ok=True)
    path = results / "thread_wait.csv"
    if a.plot_only:
        with open(path) as f:
            rows = list(csv.DictReader(f))
    else:
        rows = []
        with tempfile.TemporaryDirectory() as tmp:
            for load in ("idle", "one busy process"):
                busy = subprocess.Popen(["yes"], stdout=subprocess.DEVNULL) if load != "idle" else None
                try:
                    for scene, cmd in scenes(a.build, tmp).items():
                        for repeat in range(a.repeats):
                            for setting, extra in SETTINGS.items():  # interleaved, so drift hits each alike
                                env = {k: v for k, v in os.environ.items() if not k.startswith("OMP_")}
                                env.update(extra)
                                wall = timed(cmd, env)
                                rows.append({"load": load, "scene": scene, "setting": setting, "repeat": repeat,
                                             "wall_s": wall})
                                print(rows[-1], flush=True)
                finally:
                    if busy:
                        busy.kill()
                        busy.wait()
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    median = {}
    for r in rows:
        median.setdefault((r["load"], r["scene"], r["setting"]), []).append(float(r["wall_s"]))
    median = {k: statistics.median(v) for k, v in median.items()}
    loads = list(dict.fromkeys(r["load"] for r in rows))
    scene_names = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(1, len(scene_names), figsize=(5.5 * len(scene_names), 4))
    for ax, scene in zip(axes, scene_names):
        width = 0.8 / len(SETTINGS)
        for k, setting in enumerate(SETTINGS):
            ratios = [median[(load, scene, setting)] / median[(load, scene, "1 thread")] for load in loads]
            xs = [i + (k - 1) * width for i in range(len(loads))]
            ax.bar(xs, ratios, width, label=setting)
            for x, r in zip(xs, ratios):
                ax.text(x, r, f"{r:.2f}", ha="center", va="bottom", fontsize=7)
        for i, load in enumerate(loads):
            print(f"{scene:24s} {load:17s} " + "  ".join(
                f"{s}: {median[(load, scene, s)]:.3f} s ({median[(load, scene, s)] / median[(load, scene, '1 thread')]:.2f})"
                for s in SETTINGS))
        ax.axhline(1, color="grey", lw=0.8)
        ax.set_xticks(range(len(loads)))
        ax.set_xticklabels(loads)
        ax.set_ylabel("wall time over one thread's (median)")
        ax.set_title(scene, fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle("OpenMP wait policy: two threads against one, idle and beside a busy process (2 cores)", fontsize=10)
    fig.tight_layout()
    fig.savefig(results / "thread_wait.png", dpi=120)


if __name__ == "__main__":
    main()
