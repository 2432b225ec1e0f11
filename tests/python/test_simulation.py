"""The time loop from Python: the dam break stepped from Python gives the dambreak app's numbers bitwise; a tank stays
hydrostatic; the guard's stop and bad configurations raise with the library's message."""
import csv
import os
import re

import numpy as np
import pytest
import scipy.io

import sparsemps
from conftest import DAMBREAK_END, SOURCE_DIR, dambreak_simulation, read_vtp


def test_dambreak_from_python_matches_the_app_bitwise(dambreak_run):
    sim = dambreak_simulation()
    reports, ppe_100 = [], None
    while sim.time < DAMBREAK_END - 1e-12:  # the app's loop (Scene::done)
        info = sim.step()
        reports.append(info.solve)
        if info.step == 100:
            ppe_100 = sim.last_ppe
    # Every pressure solve as the app logged it (17 digits: a float's every bit).
    with open(dambreak_run / "solves.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(reports) == sim.steps == 123
    for row, report in zip(rows, reports):
        assert (row["backend"], int(row["iterations"])) == (report.backend, report.iterations)
        assert float(row["relative_residual"]) == report.relative_residual
    assert sum(r.iterations for r in reports) > 2000  # real solves: the column is falling
    # The last frame: every particle's position, velocity, pressure and id.
    frame = read_vtp(dambreak_run / "frames" / "dambreak_0001.vtp")
    state = sim.particles
    active = state.kind != sparsemps.Kind.ghost.value
    assert np.array_equal(frame["points"][:, 0], state.x[active])
    assert np.array_equal(frame["points"][:, 1], state.y[active])
    assert np.array_equal(frame["velocity"][:, 0], state.u[active])
    assert np.array_equal(frame["velocity"][:, 1], state.v[active])
    assert np.array_equal(frame["pressure"], state.p[active])
    assert np.array_equal(frame["id"], state.id[active])
    assert frame["TIME"] == sim.time  # the app's frame carries the time it was written at
    assert np.abs(state.v[state.kind == 0]).max() > 0.3  # it moved
    # Step 100's PPE as the app exported it.
    a = scipy.io.mmread(dambreak_run / "ppe" / "step_000100.mtx").tocsr()
    a.sort_indices()
    b = np.asarray(scipy.io.mmread(dambreak_run / "ppe" / "step_000100_rhs.mtx")).ravel()
    m = ppe_100.matrix
    assert np.array_equal(m.indptr, a.indptr) and np.array_equal(m.indices, a.indices)
    assert np.array_equal(m.data, a.data) and np.array_equal(ppe_100.rhs, b)
    assert (m != m.T).nnz == 0
    np.linalg.cholesky(m.toarray())  # positive definite in the disordered, splashing state too


def test_tank_in_a_few_lines_stays_at_rest_with_hydrostatic_pressure():
    l0, width, height = 0.01, 0.2, 0.2
    p = sparsemps.Particles().fill_rectangle((0, 0, width, height), l0)
    p.add_rectangle_walls((0, 0, width, 1.2 * height), l0, sides="left|right|bottom")
    sim = sparsemps.Simulation(p, (-0.06, 0.26, -0.06, 0.36), l0=l0, fy=-9.81, dt_max=1e-3)
    info = sim.run(end_time=0.1)
    assert info.step == sim.steps == 100 and sim.time == pytest.approx(0.1)
    assert info.dt_limit == "dt_max" and info.unknowns == 440 and info.max_speed < 1e-6
    state = sim.particles
    fluid = state.kind == 0
    deep = fluid & (state.y < height - 4 * l0)
    exact = 1000 * 9.81 * (height - state.y)
    assert np.abs(state.p[deep] / exact[deep] - 1).max() < 0.01
    assert set(sim.phase_times) >= {"neighbors", "assemble", "solve", "total"}
    assert sim.solver_spec.startswith("auto:")


def test_guard_stop_raises_simulation_error_and_keeps_the_state():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    p.u = np.ones(len(p))
    sim = sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3, max_speed=0.5, reorder_every=0)
    with pytest.raises(sparsemps.SimulationError,
                       match=r"step 1 \(t = 0.001 s, dt = 0.001 s, dt limit dt_max, pressure treatment none, gradient "
                             r"min-reference\): particle 0 moves at 1 m/s, "
                             r"above max_speed 0.5 m/s \(reduce dt_max\)"):
        sim.step()
    assert sim.steps == 0 and sim.time == 0.0
    assert np.array_equal(sim.particles.x, p.x) and np.array_equal(sim.particles.u, p.u)


def test_config_fields_round_trip_and_misspellings_are_refused():
    fields = sparsemps.SimulationConfig().to_dict()
    assert fields["solver"] == "auto" and fields["gamma"] == 0.99 and fields["weight"] == "bounded"
    changed = dict(fields, l0=0.02, gamma=0.5, weight="classic", pressure_gradient="corrected", reorder_every=0,
                   warm_start=False, solver="cholmod")
    config = sparsemps.SimulationConfig(**changed)
    assert config.to_dict() == changed
    config.gamma = 0.25
    assert config.gamma == 0.25
    with pytest.raises(ValueError, match=r"SimulationConfig has no field 'gama'; valid fields: l0, "):
        sparsemps.SimulationConfig(gama=0.5)
    with pytest.raises(TypeError, match=r"SimulationConfig.warm_start takes True or False, got int"):
        sparsemps.SimulationConfig(warm_start=1)
    with pytest.raises(TypeError, match=r"SimulationConfig.gamma takes a number, got str"):
        sparsemps.SimulationConfig(gamma="0.5")
    with pytest.raises(ValueError, match=r"unknown weight 'gauss'; valid: bounded, classic"):
        sparsemps.SimulationConfig(weight="gauss")
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    with pytest.raises(ValueError, match=r"simulation config: gamma must be in \[0, 1\], got 2"):
        sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3, gamma=2.0)
    with pytest.raises(ValueError, match=r"unknown solver 'fast'"):
        sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3, solver="fast")
    with pytest.raises(ValueError, match=r"particle 5 at \(0.055, 0.005\) starts outside the domain"):
        sparsemps.Simulation(p, (0, 0.05, 0, 0.1), l0=0.01, dt_max=1e-3)
    with pytest.raises(ValueError, match=r"give end_time, steps or both"):
        sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3).run()


def test_particles_from_arrays_and_geometry():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.4, 0.4), 0.01)
    assert len(p) == p.count("fluid") == 1600
    assert p.x.min() == pytest.approx(0.005) and p.y.max() == pytest.approx(0.395)
    p.add_rectangle_walls((0, 0, 0.4, 0.5), 0.01, sides=["left", "right", "bottom"], wall_layers=1, dummy_layers=4)
    assert p.count(sparsemps.Kind.wall) == 50 + 50 + 42 and np.array_equal(p.id, np.arange(len(p)))
    q = sparsemps.Particles(p.x, p.y, p.kind, u=np.full(len(p), 0.5), group=np.full(len(p), 3))
    assert np.array_equal(q.kind, p.kind) and np.all(q.u == 0.5) and np.all(q.group == 3) and np.all(q.v == 0)
    assert len(sparsemps.Particles([0.0, 1.0], [0.0, 0.0], "wall")) == 2
    with pytest.raises(ValueError, match=r"u has length 2, expected 2350"):
        p.u = [1.0, 2.0]
    with pytest.raises(ValueError, match=r"unknown particle kind 'water'"):
        sparsemps.Particles([0.0], [0.0], "water")
    with pytest.raises(ValueError, match=r"unknown side 'front'"):
        p.add_rectangle_walls((0, 0, 1, 1), 0.01, sides="front")


def test_frames_written_from_python_read_back_bitwise(tmp_path):
    sim = dambreak_simulation()
    sim.run(steps=5)
    state = sim.particles
    speed = np.hypot(state.u, state.v)
    sparsemps.write_vtp(str(tmp_path / "frame.vtp"), state, {"speed": speed}, time=sim.time,
                        vectors={"twice": (2 * state.u, 2 * state.v)})
    frame = read_vtp(tmp_path / "frame.vtp")
    assert np.array_equal(frame["points"][:, 1], state.y) and np.array_equal(frame["pressure"], state.p)
    assert np.array_equal(frame["speed"], speed) and np.array_equal(frame["kind"], state.kind)
    assert frame["TIME"] == sim.time > 0
    assert frame["twice"].shape == (len(state.u), 3) and np.array_equal(frame["twice"][:, 0], 2 * state.u)
    assert np.array_equal(frame["twice"][:, 1], 2 * state.v) and not frame["twice"][:, 2].any()
    with pytest.raises(ValueError, match=r"speed has length 3"):
        sparsemps.write_vtp(str(tmp_path / "bad.vtp"), state, {"speed": [1.0, 2.0, 3.0]}, time=0.0)
    with pytest.raises(TypeError):  # the time is not optional: every frame carries it
        sparsemps.write_vtp(str(tmp_path / "bad.vtp"), state)


def test_components_refuse_parameters_out_of_range():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    sim = sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3)
    with pytest.raises(ValueError, match=r"collision distance must be in \(0, 1\) l0"):
        sim.add_particle_collision(1.5)
    with pytest.raises(ValueError, match=r"restitution must be in \[0, 1\]"):
        sim.add_particle_collision(0.8, -0.1)
    with pytest.raises(ValueError, match=r"asymmetry fraction must be in \(0, 10\]"):
        sim.add_asymmetry_surface(0.0)


def test_particles_refuse_non_finite_positions_velocities_and_pressures():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    for name in ["x", "y", "u", "v", "p"]:
        values = np.zeros(len(p))
        values[7] = np.nan
        with pytest.raises(ValueError, match=rf"^{name}\[7\] is nan: every entry must be a finite number$"):
            setattr(p, name, values)
        values[7], values[2] = 0.0, -np.inf
        with pytest.raises(ValueError, match=rf"^{name}\[2\] is -inf"):
            setattr(p, name, values)
    assert np.isfinite(p.x).all() and np.isfinite(p.u).all()  # the refused arrays left nothing behind
    with pytest.raises(ValueError, match=r"^p\[1\] is inf"):
        sparsemps.Particles([0.0, 1.0], [0.0, 0.0], "fluid", p=[0.0, np.inf])
    with pytest.raises(ValueError, match=r"^x\[0\] is nan"):
        sparsemps.Particles([np.nan, 1.0], [0.0, 0.0], "fluid")


def test_run_refuses_an_end_it_cannot_reach_and_fewer_than_one_step():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    sim = sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.01, dt_max=1e-3)
    # NaN and Inf used to run until the guard tripped; a past end_time or steps < 1 returned at step 0 silently.
    for bad in [np.nan, np.inf, -np.inf]:
        with pytest.raises(ValueError, match=rf"^run: end_time = {bad!r} is not a finite time; give the time to stop"):
            sim.run(end_time=bad)
    for bad in [-1.0, 0.0, 5e-13]:
        with pytest.raises(ValueError, match=rf"^run: end_time = {bad!r} s is not beyond the current time 0.0 s; "
                                             r"give a later end_time$"):
            sim.run(end_time=bad)
    for bad in [-1, 0]:
        with pytest.raises(ValueError, match=rf"^run: steps = {bad} takes no step; give steps >= 1$"):
            sim.run(steps=bad)
        with pytest.raises(ValueError, match=r"takes no step"):
            sim.run(end_time=1.0, steps=bad)
    with pytest.raises(ValueError, match=r"^run: end_time = 1000000.0 s is at least 1e\+09 steps of at most "
                                         r"dt_max = 0.001 s away, more than the 1e8 a run may take"):
        sim.run(end_time=1e6)
    with pytest.raises(ValueError, match=r"^run: steps = 1000000000 is more than the 1e8 a run may take"):
        sim.run(steps=10**9)
    assert sim.steps == 0 and sim.time == 0.0  # nothing ran
    assert sim.run(end_time=1e6, steps=2).step == 2  # bounded by the step count: taken
    with pytest.raises(ValueError, match=r"end_time = 0.002 s is not beyond the current time 0.002 s"):
        sim.run(end_time=sim.time)
    assert sim.run(end_time=0.003).step == 3


def test_unclear_arguments_get_messages_that_say_what_is_expected():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    domain = r"the domain must be a sparsemps.Domain or a 4-tuple \(xmin, xmax, ymin, ymax\), got "
    with pytest.raises(TypeError, match=domain + "NoneType$"):  # was pybind11's "Unable to cast"
        sparsemps.Simulation(p, None, l0=0.01, dt_max=1e-3)
    with pytest.raises(TypeError, match=domain + "str$"):
        sparsemps.Simulation(p, "box", l0=0.01, dt_max=1e-3)
    with pytest.raises(ValueError, match=domain + "3 numbers$"):
        sparsemps.Simulation(p, (0, 1, 0), l0=0.01, dt_max=1e-3)
    with pytest.raises(TypeError, match=r"^rect must be \(x0, y0, x1, y1\), got NoneType$"):
        sparsemps.Particles().fill_rectangle(None, 0.01)
    with pytest.raises(ValueError, match=r"^inner holds nan; give finite coordinates$"):
        sparsemps.Particles().add_rectangle_walls((0, 0, np.nan, 1), 0.01)
    with pytest.raises(ValueError, match=r"^x must be 1-D, got a scalar$"):
        sparsemps.Particles(0.5, 0.5, "fluid")


def test_requests_too_large_are_refused_before_allocating_with_the_estimate():
    # Each used to raise a bare MemoryError (std::bad_alloc) after trying.
    more = r" particles \([0-9.e+]+ GB at 2 KB each; this machine has [0-9.e+]+ GB\), more than the [0-9.e+]+ a scene "
    with pytest.raises(ValueError, match=r"^fill_rectangle would make about 1e\+16" + more +
                                         r"may hold here; use a larger l0 or a smaller rectangle$"):
        sparsemps.Particles().fill_rectangle((0, 0, 1e4, 1e4), 1e-4)
    with pytest.raises(ValueError, match=r"^add_rectangle_walls would make about 2e\+09" + more):
        sparsemps.Particles().add_rectangle_walls((0, 0, 1e4, 1e4), 1e-4)
    layers = 2 * (2**31 - 1)  # their sum would overflow the library's int
    frame = re.escape(f"{(100 + 2 * layers) ** 2 - 100**2:.3g}")
    with pytest.raises(ValueError, match=r"^add_rectangle_walls would make about " + frame + more):
        sparsemps.Particles().add_rectangle_walls((0, 0, 1, 1), 0.01, wall_layers=2**31 - 1, dummy_layers=2**31 - 1)
    # The particles already held count too: a row that alone would fit, on top of 100 held, does not.
    limit = min(2e7, os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2000)
    p = sparsemps.Particles().fill_rectangle((0, 0, 1, 1), 0.1)
    row = int(limit) - 50
    with pytest.raises(ValueError, match=r"^fill_rectangle would make about " + re.escape(f"{row + 100:.3g}")):
        p.fill_rectangle((0, 0, row, 1), 1.0)
    assert len(p) == 100  # left as it was
    # A domain of 1e14 cells for the neighbour search is refused by the grid before it allocates (it had raised
    # the MemoryError of a std::bad_alloc).
    with pytest.raises(ValueError, match=r"^CellGrid: the domain, 2e\+06 m x 2e\+06 m, would hold 9.52e\+13 cells .* "
                                         r"more than the 1e8 a grid may hold"):
        sparsemps.Simulation(p, (-1e6, 1e6, -1e6, 1e6), l0=0.1, dt_max=1e-3)


@pytest.mark.parametrize("gradient", ["min-reference", "corrected-min-reference"])
def test_the_spheric_column_falls_as_the_record_once_its_clock_is_moved(gradient):
    """SPHERIC Test 2's column (Kleefsman et al. 2005) collapsing in 2-D at H/22 with the 3-D dam break's numerics:
    its level at the gauge H4, inside the column, follows the experiment's record within 2.5 mm over 0.1-0.4 s once
    the record's clock is moved by 30-70 ms (bench/spheric2_clock.py: 59 and 39 ms with these gradients at H/22; 47
    and 39 ms at H/88), and misses it by more than 8 mm on the record's own clock: the record starts after the
    release (docs/dambreak3d.md)."""
    import sys
    sys.path.insert(0, str(SOURCE_DIR / "bench"))
    import spheric2_clock

    samples = spheric2_clock.collapse_2d(sparsemps, 0.025, end_time=0.4, gradient=gradient)
    delay, shifted_error, error = spheric2_clock.delay(samples[:, 0], samples[:, 1])
    assert 0.03 <= delay <= 0.07
    assert shifted_error < 0.0025
    assert error > 0.008
