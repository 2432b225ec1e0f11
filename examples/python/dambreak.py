#!/usr/bin/python3
"""The classic dam break from Python (Martin & Moyce's column, twice as high as wide), in the way a Python user
works: a scene from the geometry helpers, the step run to each output time, a frame and its series written and read
back, the particles edited and pushed back, and the surge front plotted against Martin & Moyce's experiment.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/dambreak.py [END_TIME_S] [OUT_DIR]

It checks what must hold whatever the spacing (the water conserved, the front never going back by more than half a
spacing, the frames read back bit for bit) and exits 1 if not; the tests run it as it is (examples/README.md).
"""
import math
import sys
from pathlib import Path

import numpy as np

import sparsemps as sps

ROOT = Path(__file__).resolve().parents[2]


def main(end_time=0.4, out=Path("runs/example_dambreak")):
    out.mkdir(parents=True, exist_ok=True)
    a, g = 0.146, 9.81                       # the column's width [m] and gravity, as apps/dambreak sets them
    H, L, T, l0 = 2 * a, 4 * a, 3 * a, a / 20  # column height, tank length and wall height, spacing
    p = sps.Particles().fill_rectangle((0, 0, a, H), l0)
    p.add_rectangle_walls((0, 0, L, T), l0, sides="left|right|bottom")
    # The dam break's own numerics (apps/dambreak): the higher-order source and the dynamic stabilisation of close
    # pairs, which is what lets it run without collisions (docs/pressure.md).
    sim = sps.Simulation(p, (-6 * l0, L + 6 * l0, -6 * l0, T + H / 2 + 6 * l0), l0=l0, fy=-g, gamma=0.01,
                         dt_max=0.2 * l0 / math.sqrt(2 * g * H), shifting=0.5, shift_along_free_surface=True,
                         higher_order_source=True, stabilisation_distance=0.85)
    fluid_at_start = int((sim.particles.kind == sps.Kind.fluid.value).sum())

    # A nudge pushed back into the run: the column starts with a small downward velocity (particles are a copy;
    # assigning the edited copy hands it back).
    state = sim.particles
    state.v = np.where(state.kind == sps.Kind.fluid.value, -0.01, 0.0)
    sim.particles = state

    times, fronts, frames = [], [], []
    for k in range(1, 9):
        info = sim.run(end_time=end_time * k / 8)
        q = sim.particles
        fluid = q.kind == sps.Kind.fluid.value
        times.append(info.time)
        fronts.append(q.x[fluid].max() + l0 / 2)
        frames.append(out / f"frame_{k:02d}.vtp")
        sps.write_vtp(str(frames[-1]), q, {"speed": np.hypot(q.u, q.v)}, time=info.time)
        print(f"t = {info.time:.3f} s  step {info.step}  {info.solve.backend} {info.solve.iterations} it  "
              f"front {fronts[-1] / a:.2f} a")

    # The last frame read back as particles, bit for bit.
    back, t_back = sps.read_frame(str(frames[-1]))
    ok = t_back == times[-1] and np.array_equal(back.x, sim.particles.x) and np.array_equal(back.p, sim.particles.p)
    fluid_now = int((sim.particles.kind == sps.Kind.fluid.value).sum())
    ok = ok and fluid_now == fluid_at_start and all(b >= f - 0.5 * l0 for f, b in zip(fronts, fronts[1:]))

    # The front against Martin & Moyce (T = t sqrt(2g/a), Z = x/a).
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3.5))
    for name, marker in (("mm_data_1.txt", "o"), ("mm_data_2.txt", "s")):
        data = np.loadtxt(ROOT / "data" / "dambreak" / name)
        ax.plot(data[:, 0], data[:, 1], marker, mfc="none", label=f"Martin & Moyce 1952 ({name[:-4]})")
    ax.plot(np.array(times) * math.sqrt(2 * g / a), np.array(fronts) / a, "-", label=f"SparseMPS from Python, l0 = a/20")
    ax.axhline(L / a, ls=":", c="gray", label="the tank's far wall")
    ax.set(xlabel="T = t sqrt(2g/a)", ylabel="front Z = x/a", xlim=(0, 5), ylim=(0, 7),
           title=f"Dam break, a = {a} m, to t = {times[-1]:.2f} s")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "front.png", dpi=120)
    print(f"fluid particles {fluid_at_start} -> {fluid_now}; frames read back bit for bit: {t_back == times[-1]}; "
          f"front plot in {out / 'front.png'}: {'ok' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.4,
                  Path(sys.argv[2]) if len(sys.argv) > 2 else Path("runs/example_dambreak")))
