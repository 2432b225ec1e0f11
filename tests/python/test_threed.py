"""3-D from Python: Particles3 / Domain3 / Simulation3 give the hydrostatic app's 3-D tank bitwise and the pressure
rho g (H - z); the particles' field list and (N, 3) arrays round-trip; bad shapes and names raise naming the cause."""
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import sparsemps
from conftest import read_vtp

L0, WIDTH, HEIGHT, END = 0.05, 0.4, 0.4, 0.05  # apps/hydrostatic --dim 3 at 8 x 8 x 8 fluid particles


def tank3():
    """The 3-D tank as apps/hydrostatic/tank.cpp makes it (make_particles, make_domain, make_config)."""
    p = sparsemps.Particles3()
    p.fill_box((0, 0, 0, WIDTH, WIDTH, HEIGHT), L0, "fluid")
    p.add_box_walls((0, 0, 0, WIDTH, WIDTH, 1.2 * HEIGHT), L0, "x_low|x_high|y_low|y_high|z_low", 1, 4)
    m = 6 * L0
    domain = sparsemps.Domain3(-m, WIDTH + m, -m, WIDTH + m, -m, 1.5 * HEIGHT + m)
    return sparsemps.Simulation3(p, domain, l0=L0, rho=1000.0, nu=1e-6, fz=-9.81, gamma=0.99, dt_max=1e-3,
                                 solver="auto", dt_option="--dt")


def test_the_3d_tank_from_python_is_the_apps_bitwise(tmp_path):
    app = Path(os.environ["SPARSEMPS_BUILD_DIR"]) / "apps" / "hydrostatic" / "hydrostatic"
    subprocess.run([str(app), "--dim", "3", "--dx", str(L0), "--end-time", str(END), "--window", "0.02", "--frames",
                    "1", "--out", str(tmp_path)], check=True, capture_output=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    frame = read_vtp(tmp_path / "frames" / "tank_0001.vtp")
    sim = tank3()
    sim.run(end_time=END)
    q = sim.particles
    assert frame["TIME"] == sim.time
    assert np.array_equal(frame["points"], q.positions)
    assert np.array_equal(frame["velocity"], q.velocities)
    assert np.array_equal(frame["pressure"], q.p)
    assert np.array_equal(frame["id"], q.id)
    # And the physics: rho g (H - z) within the bound of the solver's tolerance (docs/method.md: 6.2e-3 Pa at 0.02 m).
    fluid = q.kind == sparsemps.Kind.fluid.value
    assert np.max(np.abs(q.p[fluid] - 1000.0 * 9.81 * (HEIGHT - q.z[fluid]))) < 1e-2
    start = tank3().particles  # in creation order; the step reorders by cell, id follows each particle
    assert np.max(np.abs(q.positions - start.positions[q.id])) < 1e-6 * L0


def test_the_field_list_and_the_n_by_3_arrays_round_trip():
    p = sparsemps.Particles3(np.array([[0.0, 0.0, 0.0], [0.1, 0.2, 0.3]]), ["fluid", "wall"][0],
                             velocities=[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], p=[7.0, 8.0], group=[1, 2])
    assert len(p) == 2 and p.count("fluid") == 2
    assert np.array_equal(p.positions, np.column_stack([p.x, p.y, p.z]))
    assert np.array_equal(p.velocities, [[1, 2, 3], [4, 5, 6]])
    assert np.array_equal(p.w, [3, 6]) and np.array_equal(p.p, [7, 8]) and np.array_equal(p.group, [1, 2])
    assert np.array_equal(p.id, [0, 1])
    p.z = [0.5, 0.6]
    p.kind = [0, 2]
    p.velocities = np.zeros((2, 3))
    assert np.array_equal(p.positions[:, 2], [0.5, 0.6]) and np.array_equal(p.kind, [0, 2])
    assert not p.u.any() and not p.v.any() and not p.w.any()
    with pytest.raises(AttributeError):
        p.id = [5, 6]
    flat = sparsemps.Particles()
    flat.fill_rectangle((0, 0, 0.03, 0.02), 0.01)
    assert flat.positions.shape == (6, 2)
    flat.positions = flat.positions[::-1]
    assert np.array_equal(flat.x, [0.025, 0.015, 0.005, 0.025, 0.015, 0.005])


def test_3d_frames_hold_every_field(tmp_path):
    p = sparsemps.Particles3()
    p.fill_box((0, 0, 0, 0.03, 0.02, 0.01), 0.01)
    p.velocities = np.arange(18.0).reshape(6, 3)
    sparsemps.write_vtp(str(tmp_path / "f.vtp"), p, {"s": np.arange(6.0)}, time=0.25,
                        vectors={"a": (p.x, p.y, p.z)})
    f = read_vtp(tmp_path / "f.vtp")
    assert f["TIME"] == 0.25
    assert np.array_equal(f["points"], p.positions) and np.array_equal(f["velocity"], p.velocities)
    assert np.array_equal(f["a"], p.positions) and np.array_equal(f["s"], np.arange(6.0))


@pytest.mark.parametrize("make, error, message", [
    (lambda: sparsemps.Particles3(np.zeros((2, 2)), "fluid"), ValueError, r"^positions must have shape \(N, 3\), got \(2, 2\)$"),
    (lambda: sparsemps.Particles3([[0, 0, np.nan]], "fluid"), ValueError, r"^positions\[0, 2\] is nan: every entry"),
    (lambda: sparsemps.Particles3([[0, 0, 0]]), ValueError, r"kind is required"),
    (lambda: sparsemps.Particles3([[0, 0, 0]], "fluid", velocities=np.zeros((2, 3))), ValueError,
     r"^velocities must have shape \(1, 3\), got \(2, 3\)$"),
    (lambda: sparsemps.Particles3().add_box_walls((0, 0, 0, 1, 1, 1), 0.1, "top"), ValueError,
     r"^unknown face 'top'; valid: x_low, x_high, y_low, y_high, z_low, z_high$"),
    (lambda: sparsemps.Particles3().fill_box((0, 0, 1, 1), 0.1), ValueError, r"^box must be \(x0, y0, z0, x1, y1, z1\)"),
    (lambda: tank3().__class__(sparsemps.Particles3([[0.1, 0.1, 0.1]], "fluid"), (0, 1, 0, 1), l0=0.1, dt_max=1e-3),
     ValueError, r"Domain3 or a 6-tuple"),
    (lambda: sparsemps.Simulation(sparsemps.Particles([0.1], [0.1], "fluid"), (0, 1, 0, 1), l0=0.1, dt_max=1e-3,
                                  fz=-9.81), ValueError, r"fz = -9.81 is a 3-D body force"),
])
def test_bad_3d_input_raises_naming_the_cause(make, error, message):
    with pytest.raises(error, match=message):
        make()


def test_the_wall_backstop_puts_fluid_through_the_floor_back_on_it():
    """A lone particle stepping 0.5 mm through the floor ends on it with no velocity into it, its sideways speed
    kept (tests/test_3d.cpp checks every face); a box whose corners are swapped is refused."""
    p = sparsemps.Particles3([[0.1, 0.5, 0.0005]], "fluid", velocities=[[0.3, 0.0, -1.0]])
    sim = sparsemps.Simulation3(p, (-0.5, 1.5, -0.5, 1.5, -0.5, 1.5), l0=0.05, dt_max=1e-3)
    sim.add_wall_backstop((0, 0, 0, 1, 1, 1), [(0.4, 0.4, 0, 0.6, 0.6, 0.2)])
    sim.step()
    q = sim.particles
    assert q.z[0] == 0.0 and q.w[0] == 0.0
    assert abs(q.x[0] - (0.1 + 0.3e-3)) < 1e-12 and q.u[0] == 0.3
    with pytest.raises(ValueError, match="an obstacle: each lower corner must lie below its upper"):
        sim.add_wall_backstop((0, 0, 0, 1, 1, 1), [(0.6, 0.4, 0, 0.4, 0.6, 0.2)])
    with pytest.raises(ValueError, match="the slack must be finite and at least 0 m"):
        sim.add_wall_backstop((0, 0, 0, 1, 1, 1), slack=-0.01)


def test_the_wall_backstop_leaves_fluid_within_its_slack():
    """The same step through the floor with a slack of 1 mm: the particle 0.8 mm under the floor stays there."""
    p = sparsemps.Particles3([[0.1, 0.5, 0.0005]], "fluid", velocities=[[0.3, 0.0, -1.3]])
    sim = sparsemps.Simulation3(p, (-0.5, 1.5, -0.5, 1.5, -0.5, 1.5), l0=0.05, dt_max=1e-3)
    sim.add_wall_backstop((0, 0, 0, 1, 1, 1), slack=1e-3)
    sim.step()
    assert abs(sim.particles.z[0] - (0.0005 - 1.3e-3)) < 1e-12 and sim.particles.w[0] == -1.3
