#!/usr/bin/python3
"""sparsemps-plot on a short run of every scene (docs/plots.md): each expected figure is drawn, is a real picture
(not one flat colour), carries a title made from the run's own parameters (its spacing, its Reynolds number) and
draws the reference it is judged against (the experiment's or the exact solution's series, by its legend).

  tests/plot_apps.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image
import numpy as np

SOURCE = Path(__file__).resolve().parent.parent
PLOT = SOURCE / "scripts" / "sparsemps-plot"
# name: (app, arguments, {figure: words its legend must hold (None: any)})
CASES = {
    "dambreak-seed": ("dambreak", "--column seed --end-time 0.3 --frames 1 --probes {examples}/probes/dambreak_classic.toml",
                      {"front.png": "Martin & Moyce", "level.png": None, "pressure.png": "Buchner",
                       "probes.png": None}),
    "dambreak-3d": ("dambreak", "--dim 3 --dx 0.08 --end-time 0.2 --frames 1",
                    {"pressure.png": "Kleefsman", "level.png": "Kleefsman"}),
    "structure-csm3": ("structure", "--scene csm3 --end-time 0.2 --frames 1", {"tip.png": "Turek & Hron", "energy.png": None}),
    "fsi-plate": ("fsi", "--end-time 0.05 --frames 1", {"tip.png": "load"}),
    "acoustic": ("acoustic", "--case free --size 20 --l0 0.5 --end-time 0.02 --maps 0.01,0.02", {"map_00.png": None}),
    "poiseuille": ("poiseuille", "--mode body-force --across 10 --end-time 2 --frames 1",
                   {"profile.png": "exact", "centerline.png": "exact"}),
    "rotating": ("rotating", "--scene couette --across 8 --times 0.05,0.1 --frames 1", {"couette.png": "exact"}),
    "hydrostatic": ("hydrostatic", "--end-time 0.2 --window 0.1 --frames 1", {"pressure.png": "rho g (H - y)"}),
    # a scene file's run: its probes, titled from the file's title
    "run": ("run", "{examples}/scenes/hydrostatic.toml --end-time 0.1 --frames 1", {"probes.png": "middle"}),
    # an acoustic file's run as acoustic's; a body alone: its energies and its probe
    "run-acoustic": ("run", "{examples}/scenes/acoustic_free.toml --end-time 0.01",
                     {"map_00.png": None, "centerline.png": "exact"}),
    "run-structure": ("run", "{examples}/scenes/structure_csm3.toml --end-time 0.05 --frames 1",
                      {"energy.png": "kinetic", "probes.png": "tip"}),
}


def main():
    build = Path(sys.argv[1])
    failures = []
    env = dict(os.environ, OMP_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        for name, (app, args, figures) in CASES.items():
            out = Path(tmp) / name
            args = args.format(examples=SOURCE / "examples").split()
            run = subprocess.run([build / "apps" / app / app, *args, "--out", out], env=env, capture_output=True,
                                 text=True)
            if run.returncode not in (0, 2):
                failures.append(f"{name}: the app exited {run.returncode}: {run.stderr[-300:]}")
                continue
            plot = subprocess.run(["/usr/bin/python3", PLOT, out], env=env, capture_output=True, text=True)
            if plot.returncode != 0:
                failures.append(f"{name}: sparsemps-plot exited {plot.returncode}: {plot.stderr[-500:]}")
                continue
            index = json.loads((out / "plots" / "index.json").read_text())
            params = json.loads((out / "summary.json").read_text())["parameters"]
            for figure, words in figures.items():
                if figure not in index:
                    failures.append(f"{name}: no {figure} (drawn: {sorted(index)})")
                    continue
                image = matplotlib.image.imread(out / "plots" / figure)
                if image.shape[0] < 200 or np.ptp(image[..., :3]) == 0:
                    failures.append(f"{name}: {figure} is no picture ({image.shape})")
                title, series = index[figure]["title"], index[figure]["series"]
                dx = params.get("dx_m") or params.get("spacing_m")
                if dx and f"{dx:.4g}" not in title:
                    failures.append(f"{name}: {figure}'s title {title!r} does not give the run's dx {dx}")
                if app == "run" and params["title"] not in title:
                    failures.append(f"run: {figure}'s title {title!r} does not give the scene file's title")
                if app == "rotating" and f"Re = {params['re']:g}" not in title:
                    failures.append(f"{name}: {figure}'s title {title!r} does not give the run's Re {params['re']}")
                if words and not any(words in s for s in series):
                    failures.append(f"{name}: {figure} draws {series}, nothing of {words!r}")
            if app == "acoustic" or name == "run-acoustic":
                maps = [f for f in index if f.startswith("map_")]
                frames = sorted((out / "frames").glob("*.vtp"))
                if len(maps) != len(frames) or not all("t = " in index[m]["title"] for m in maps):
                    failures.append(f"acoustic: {len(maps)} maps for {len(frames)} frames, titles "
                                    f"{[index[m]['title'] for m in maps]}")
            print(f"{name}: {len(index)} figures: {', '.join(sorted(index))}")
        bad = subprocess.run(["/usr/bin/python3", PLOT, tmp], capture_output=True, text=True)
        if bad.returncode != 1 or "holds no summary.json" not in bad.stderr:
            failures.append(f"a folder with no summary.json gave exit {bad.returncode}: {bad.stderr!r}")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
