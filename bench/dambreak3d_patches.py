#!/usr/bin/python3
"""P1's first impact read with other patches (docs/dambreak3d.md): a 3-D dam break run with frames close together
(`dambreak --dim 3 --end-time 0.55 --frames 220 --out RUN`) is read back, and at every frame from 0.3 s on P1 is the
mean pressure of the fluid and wall particles on the box's face within ALONG l0 of the sensor along it and ACROSS l0
of it across, for ALONG and ACROSS in 0.5, 1, 1.5, 2 (the app's patch: 2 and 2). Each patch's arrival (P1 first at
0.25 rho g 0.55 = 1,349 Pa) and first peak (the largest 0.024 s moving average within 0.118 s after it) are printed
as the app defines them, here on the frames' times. Then the app's patch read by kind (its fluid particles alone, its wall
particles alone) and the share of its wall particles that read 0 (dry: left out of the pressure system) over the
0.118 s after the arrival.

  bench/dambreak3d_patches.py BUILD_DIR RUN
"""
import glob
import json
import sys
from pathlib import Path

import numpy as np

SENSOR_Y, SENSOR_Z = 0.5, 0.021  # P1 (data/dambreak/spheric2_sensors.csv)
THRESHOLD, WINDOW, AFTER = 1349.0, 0.024, 0.118


def main():
    build, run = Path(sys.argv[1]), Path(sys.argv[2])
    sys.path.insert(0, str(build / "python"))
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "python"))
    from conftest import read_vtp

    parameters = json.loads((run / "summary.json").read_text())["parameters"]
    l0, box = parameters["dx_m"], parameters["box_m"]  # box: x0, x1, y0, y1, z1
    patches = [(a, c) for a in (0.5, 1, 1.5, 2) for c in (0.5, 1, 2)]
    kinds = {"fluid and wall (the app)": (0, 1), "fluid alone": (0,), "wall alone": (1,)}
    times, p1, by_kind, dry = [], {k: [] for k in patches}, {k: [] for k in kinds}, []
    for path in sorted(glob.glob(str(run / "frames" / "*.vtp"))):
        frame = read_vtp(path)
        if frame["TIME"] < 0.3:
            continue
        times.append(frame["TIME"])
        x, kind, pressure = frame["points"], frame["kind"], frame["pressure"]
        on_face = (kind <= 1) & (x[:, 1] > box[2]) & (x[:, 1] < box[3]) & (x[:, 2] > 0) & (x[:, 2] < box[4])
        along = np.hypot(x[:, 1] - SENSOR_Y, x[:, 2] - SENSOR_Z)
        for a, c in patches:
            inside = on_face & (along < a * l0) & (np.abs(x[:, 0] - box[1]) < c * l0)
            p1[(a, c)].append(pressure[inside].mean() if inside.any() else 0.0)
        app = on_face & (along < 2 * l0) & (np.abs(x[:, 0] - box[1]) < 2 * l0)
        for name, chosen in kinds.items():
            inside = app & np.isin(kind, chosen)
            by_kind[name].append(pressure[inside].mean() if inside.any() else 0.0)
        walls = app & (kind == 1)
        dry.append(np.mean(pressure[walls] == 0.0) if walls.any() else np.nan)
    t = np.array(times)
    print(f"{run}: {len(t)} frames from 0.3 s, l0 = {l0} m")
    print("along [l0]  across [l0]  arrival [s]  first peak [Pa]  largest frame [Pa]")
    for a, c in patches:
        print(f"{a:9g}  {c:11g}  " + impact(t, np.array(p1[(a, c)])))
    print("the app's patch, by kind     arrival [s]  first peak [Pa]  largest frame [Pa]")
    for name, p in by_kind.items():
        print(f"{name:27s}  " + impact(t, np.array(p)))
    i = int(np.argmax(np.array(by_kind["fluid and wall (the app)"]) >= THRESHOLD))
    after = (t >= t[i]) & (t <= t[i] + AFTER)
    print(f"its wall particles reading 0 (dry) over the {AFTER} s after the arrival: {np.nanmean(np.array(dry)[after]):.2f}")


def impact(t, p):
    """The arrival, first peak and largest frame after the arrival, as the app reads them."""
    if not (p >= THRESHOLD).any():
        return "not reached"
    i = int(np.argmax(p >= THRESHOLD))
    mean = np.array([p[np.abs(t - s) <= WINDOW / 2].mean() for s in t])
    after = (t >= t[i]) & (t <= t[i] + AFTER)
    return f"{t[i]:11.4f}  {mean[after].max():15.0f}  {p[after].max():18.0f}"


if __name__ == "__main__":
    main()
