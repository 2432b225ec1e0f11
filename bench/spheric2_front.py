#!/usr/bin/python3
"""Why the 3-D dam break's first impact is late (docs/dambreak3d.md): SPHERIC Test 2's column (1.228 m long, 0.55 m
high) collapsing without the box, as a 2-D run at four spacings and as a 3-D slab periodic across the flow (13
spacings wide, no side walls) at two, with the 3-D dam break's numerics (apps/dambreak's defaults when it was
measured: shifting 0.5, since turned off in 3-D; spheric2_clock.py runs without it). The front (the largest x of fluid
with a fluid neighbour within 2.1 l0, plus l0/2) is recorded every 0.01 s to 0.6 s, and the time it
needs for the 1.1675 m from the column to the box's face is set beside the experiment's P1 arrival (0.394 s, Kleefsman
et al. 2005, by docs/dambreak3d.md's definition). Writes bench/results/spheric2_front.csv (every sample),
spheric2_front_arrival.csv and spheric2_front.png.

  bench/spheric2_front.py BUILD_DIR [--runs 2:0.05,2:0.025,2:0.0125,2:0.00625,3:0.05,3:0.025,2:0.0125:0.5,2:0.0125:0.65]
                          [--end-time 0.6]

A run is DIMENSIONS:SPACING[:COLLISION], the collision distance in l0 (default 0.8, the app's). Runs already in the CSV
files and not given are kept. A run the guard stops keeps its samples up to there (guard_stop_s). One thread; the 2-D run at 0.00625 m takes about 10 minutes, the 3-D slab at 0.025 m 8.
"""
import argparse
import csv
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LENGTH, HEIGHT, TANK, G = 1.228, 0.55, 3.22, 9.81
GAP = 1.992 - 0.8245  # the column's face to the box's face towards the water [m] (apps/dambreak/box_impact.hpp)
P1_ARRIVAL = 0.394    # the experiment's P1 arrival [s] (docs/dambreak3d.md)


def simulation(sps, dim, l0, collision, shifting=0.5, **fields):
    """The column in its tank; `fields` are SimulationConfig fields over the dam break's."""
    config = dict(l0=l0, gamma=0.01, cfl=0.2, dt_max=0.2 * l0 / math.sqrt(2 * G * HEIGHT), shifting=shifting,
                  shift_along_free_surface=True, higher_order_source=True, dt_option="--cfl")
    config.update(fields)
    m = 6 * l0
    if dim == 2:
        p = sps.Particles().fill_rectangle((0, 0, LENGTH, HEIGHT), l0)
        p.add_rectangle_walls((0, 0, TANK, 1.0), l0, sides="left|right|bottom")
        sim = sps.Simulation(p, (-m, TANK + m, -m, 1.0 + HEIGHT / 2 + m), fy=-G, **config)
    else:
        width = 13 * l0  # a periodic axis must be at least three search radii (4.1 l0) long
        p = sps.Particles3().fill_box((0, 0, 0, LENGTH, width, HEIGHT), l0)
        p.add_box_walls((0, 0, 0, TANK, width, 1.0), l0, "x_low|x_high|z_low", 1, 4)
        sim = sps.Simulation3(p, sps.Domain3(-m, TANK + m, 0, width, -m, 1.0 + HEIGHT / 2 + m, periodic_y=True),
                              fz=-G, **config)
    sim.add_particle_collision(collision, 0.2)
    sim.add_asymmetry_surface(0.9)
    return sim


def front(sps, particles, dim, l0):
    import numpy as np
    fluid = particles.kind == sps.Kind.fluid.value
    r = particles.positions[fluid]
    for i in np.argsort(-r[:, 0]):
        d2 = np.sum((r - r[i]) ** 2, axis=1)
        if np.count_nonzero(d2 < (2.1 * l0) ** 2) > 1:  # itself and a neighbour: not spray
            return r[i, 0] + l0 / 2
    return float("nan")


def arrival(samples):
    """The time the front first reaches the box's face, linear between samples (NaN if it does not)."""
    for (t0, f0), (t1, f1) in zip(samples, samples[1:]):
        if f0 < GAP + LENGTH <= f1:
            return t0 + (t1 - t0) * (GAP + LENGTH - f0) / (f1 - f0)
    return float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("--runs", default="2:0.05,2:0.025,2:0.0125,2:0.00625,3:0.05,3:0.025,2:0.0125:0.5,2:0.0125:0.65")
    ap.add_argument("--end-time", type=float, default=0.6)
    args = ap.parse_args()
    os.environ["OMP_NUM_THREADS"] = "1"
    sys.path.insert(0, str(Path(args.build) / "python"))
    import sparsemps as sps

    out = ROOT / "bench" / "results"

    def key(row):
        return (int(row["dimensions"]), float(row["l0_m"]), float(row["collision_l0"]))

    def kept(path):  # rows of runs not rerun now
        if not path.exists():
            return []
        with path.open() as f:
            return [r for r in csv.DictReader(f) if key(r) not in wanted]

    runs = [tuple(map(float, r.split(":"))) for r in args.runs.split(",")]
    runs = [(int(r[0]), r[1], r[2] if len(r) > 2 else 0.8) for r in runs]
    wanted = set(runs)
    rows, table = kept(out / "spheric2_front.csv"), kept(out / "spheric2_front_arrival.csv")
    for dim, l0, collision in runs:
        sim, samples, start, stopped = simulation(sps, dim, l0, collision), [(0.0, LENGTH)], time.time(), ""
        for k in range(1, round(args.end_time / 0.01) + 1):
            try:
                sim.run(end_time=0.01 * k)
            except sps.SimulationError as e:  # the guard stopped it: keep the samples up to there
                stopped = f"{sim.time:.4f}"
                print(f"stopped: {e}", flush=True)
                break
            samples.append((sim.time, front(sps, sim.particles, dim, l0)))
        rows += [{"dimensions": dim, "l0_m": l0, "collision_l0": collision, "time_s": f"{t:.6f}", "front_m": f"{f:.6f}"}
                 for t, f in samples]
        t_box = arrival(samples)
        table.append({"dimensions": dim, "l0_m": l0, "collision_l0": collision,
                      "column_height_over_l0": round(HEIGHT / l0), "steps": sim.steps,
                      "wall_s": round(time.time() - start, 1),
                      "front_at_0.4s_m": f"{next(f for t, f in samples if t >= 0.4 - 1e-9) - LENGTH:.4f}",
                      "at_box_face_s": f"{t_box:.4f}", "against_p1_arrival": f"{t_box / P1_ARRIVAL - 1:+.3f}",
                      "guard_stop_s": stopped})
        print(table[-1], flush=True)
    rows.sort(key=lambda r: (key(r), float(r["time_s"])))
    table.sort(key=key)
    with (out / "spheric2_front.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with (out / "spheric2_front_arrival.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for row in table:
        d, l0, c = key(row)
        t = [float(r["time_s"]) for r in rows if key(r) == (d, l0, c)]
        x = [float(r["front_m"]) - LENGTH for r in rows if key(r) == (d, l0, c)]
        label = f"{d}-D{' slab' if d == 3 else ''}, l0 = {l0:g} m (H/{round(HEIGHT / l0)})"
        ax.plot(t, x, "-" if d == 2 and c == 0.8 else ("--" if d == 3 else ":"),
                label=label + ("" if c == 0.8 else f", collisions at {c:g} l0"))
    ax.axhline(GAP, color="grey", lw=0.8)
    ax.plot([P1_ARRIVAL], [GAP], "k*", ms=12, label="experiment: P1's arrival at the box's face")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front's advance from the column [m]")
    ax.set_title("SPHERIC Test 2's column without the box: the front against the spacing")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "spheric2_front.png", dpi=120)
    print(f"wrote {out / 'spheric2_front.csv'}, spheric2_front_arrival.csv, spheric2_front.png")


if __name__ == "__main__":
    main()
