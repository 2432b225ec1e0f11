#!/usr/bin/python3
"""The wave flume (examples/scenes/wave_paddle.toml) against linear piston-wavemaker theory: the two gauges' water
levels with the theory's crest and trough (still depth +- H/2), and the wave heights measured over a window, into
OUT.png and printed.

  build/release/apps/run/run examples/scenes/wave_paddle.toml --out runs/wave_paddle
  /usr/bin/python3 scripts/plot_wave_flume.py runs/wave_paddle bench/results/wave_flume.png

Theory (Biesel 1951; Dean & Dalrymple 1991): omega^2 = g k tanh(k h), and a piston of stroke S makes waves of height
H = S 2 (cosh 2kh - 1) / (sinh 2kh + 2kh).
"""
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def wavenumber(omega, depth, g=9.81):
    """k of the linear dispersion relation, by Newton's method from the deep-water guess."""
    k = omega * omega / g
    for _ in range(100):
        f = g * k * math.tanh(k * depth) - omega * omega
        df = g * math.tanh(k * depth) + g * k * depth / math.cosh(k * depth) ** 2
        k -= f / df
    return k


def main(run, out, window=(1.0, 2.0)):
    run = Path(run)
    summary = json.loads((run / "summary.json").read_text())
    params = summary["parameters"]
    motion = params["obstacles"][0]["motion"]
    depth = params["fluid"][0]["max_m"][1]
    stroke, period = 2 * motion["amplitude_m"], motion["period_s"]
    k = wavenumber(2 * math.pi / period, depth)
    height = stroke * 2 * (math.cosh(2 * k * depth) - 1) / (math.sinh(2 * k * depth) + 2 * k * depth)
    data = np.genfromtxt(run / "probes.csv", delimiter=",", names=True)
    t = data["time"]
    gauges = [name for name in data.dtype.names if name.startswith("gauge")]
    points = [p for p in summary["probes"]["probes"] if p["name"] == "gauge"][0]["points_m"]
    fig, axes = plt.subplots(len(gauges), 1, figsize=(6.5, 2.3 * len(gauges)), sharex=True, squeeze=False)
    print(f"kh = {k * depth:.3f}, wavelength {2 * math.pi / k:.3f} m, linear theory's wave height {height:.4f} m")
    for ax, name, point in zip(axes[:, 0], gauges, points):
        level = data[name]
        inside = (t >= window[0]) & (t <= window[1])
        measured = level[inside].max() - level[inside].min()
        print(f"{name} at x = {point[0]:g} m: wave height {measured:.4f} m over {window[0]:g}-{window[1]:g} s "
              f"({100 * (measured / height - 1):+.0f} %)")
        ax.plot(t, level, lw=1.0, label=f"gauge at x = {point[0]:g} m (H = {measured:.3f} m over "
                                         f"{window[0]:g}-{window[1]:g} s)")
        for sign in (1, -1):
            ax.axhline(depth + sign * height / 2, color="k", ls="--", lw=0.8,
                       label=f"linear theory, H = {height:.3f} m" if sign == 1 else None)
        ax.axvspan(*window, color="0.9", zorder=0)
        ax.set_ylabel("water level [m]")
        ax.legend(fontsize=7, loc="upper left")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"{params['title']}, l0 = {params['spacing_m']:g} m: stroke {stroke:g} m, period {period:g} s, "
                 f"depth {depth:g} m", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
