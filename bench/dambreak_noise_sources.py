#!/usr/bin/python3
"""Where the seed column's wall-pressure noise comes from (docs/dambreak.md, "What the noise is"): the seed column at
H/50 stepped from Python with the app's physics (hs, collisions, the asymmetry test, shifting along the surface, the
wall backstop), and at every step over the plateau window the 0.2 H and 0.01 H sensors' pressure beside the PPE's
source summed over regions of the water and the surface test's flips. Writes bench/results/dambreak_noise_sources.csv:
each quantity's mean, its noise (less its centred mean over 0.1 in t sqrt(g/H)) and that noise's correlation with the
sensors' noise.

  PYTHONPATH=build/release/python bench/dambreak_noise_sources.py [--results DIR]

About 1.5 minutes on one thread. The run is not the app's bit for bit (the app also removes spray over the walls,
here the domain is taller instead), so its figures are the app's in kind, not in every digit.
"""
import argparse
import math
from pathlib import Path

import numpy as np

import sparsemps as sps
from dambreak_impact import PLATEAU, centred_mean
from dambreak_pressure import write_rows

L0, H, G, TANK = 0.02, 1.0, 9.81, 5.36
START_T = 3.0  # the smoothing needs half its window before the plateau's start


def sensor(x, y, kind, p, height):
    """The app's 0.15 H sensor at `height` on the downstream wall: wall and fluid within 2 l0 of its line."""
    inside = (np.abs(x - TANK) < 2 * L0) & (np.abs(y - height) <= 0.075 * H) & (kind <= 1)
    return p[inside].mean() / (1000 * G * H)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", default="bench/results")
    args = ap.parse_args()
    start = sps.Particles().fill_rectangle((0, 0, 2 * H, H), L0)
    start.add_rectangle_walls((0, 0, TANK, 3 * H), L0, sides="left|right|bottom")
    sim = sps.Simulation(start, (-12 * L0, TANK + 12 * L0, -12 * L0, 10 * H), l0=L0, fy=-G, gamma=0.01,
                         dt_max=0.2 * L0 / math.sqrt(2 * G * H), shifting=0.5, shift_along_free_surface=True,
                         higher_order_source=True)
    sim.add_particle_collision(0.8, 0.2)
    sim.add_asymmetry_surface(0.9)
    sim.add_wall_backstop((0, 0, TANK, 3 * H), slack=0.5 * L0)
    series, flags_before = [], {}
    while sim.time * math.sqrt(G / H) < PLATEAU[1] + 0.05:
        sim.step()
        T = sim.time * math.sqrt(G / H)
        if T < START_T:
            continue
        q, ppe = sim.particles, sim.last_ppe
        x, y, p, kind, ids = (np.asarray(a) for a in (q.x, q.y, q.p, q.kind, q.id))
        solved, source = np.asarray(ppe.unknown) >= 0, np.asarray(ppe.source)
        fluid = kind == 0
        flags = dict(zip(ids[fluid], np.asarray(ppe.free_surface)[fluid] != 0))
        flips = sum(1 for i, f in flags.items() if i in flags_before and flags_before[i] != f)
        flags_before = flags
        near = solved & fluid & (x > TANK - 0.5 * H) & (y < 0.6 * H)
        series.append({"T": T, "sensor_0.2H": sensor(x, y, kind, p, 0.2 * H),
                       "sensor_0.01H": sensor(x, y, kind, p, 0.01 * H),
                       "source_near_wall": source[near].sum(),
                       "source_far_from_wall": source[solved & fluid & (x < TANK - 1.5 * H)].sum(),
                       "source_wall_particles": source[solved & (kind == 1)].sum(),
                       "source_all": source[solved].sum(), "surface_flips": flips,
                       "surface_count": int(np.asarray(ppe.free_surface)[fluid].sum())})
    T = np.array([row["T"] for row in series])
    window = (T >= PLATEAU[0]) & (T <= PLATEAU[1])
    raw = {name: np.array([row[name] for row in series]) for name in series[0] if name != "T"}
    noise = {name: (values - centred_mean(T, values, 0.1))[window] for name, values in raw.items()}
    rows = [{"quantity": name, "mean": f"{raw[name][window].mean():.4g}", "noise_sd": f"{values.std():.4g}",
             "correlation_with_0.2H": f"{np.corrcoef(values, noise['sensor_0.2H'])[0, 1]:.3f}",
             "correlation_with_0.01H": f"{np.corrcoef(values, noise['sensor_0.01H'])[0, 1]:.3f}"}
            for name, values in noise.items()]
    write_rows(Path(args.results) / "dambreak_noise_sources.csv", rows)
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()
