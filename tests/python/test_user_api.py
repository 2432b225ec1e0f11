"""What a Python user reaches for beyond the solvers and the step: frames, series and particle files read and written,
particles edited and pushed back into a simulation, and help() that names every type and says what each name does."""
import subprocess

import numpy as np
import pytest

import sparsemps
from conftest import SOURCE_DIR, app, dambreak_simulation, read_vtp


def tank(l0=0.02):
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.2, 0.1), l0)
    return p.add_rectangle_walls((0, 0, 0.2, 0.2), l0, sides="left|right|bottom")


DOMAIN = (-0.1, 0.3, -0.1, 0.3)


def same(a, b, fields=("x", "y", "u", "v", "p", "kind", "group")):
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in fields)


def test_an_apps_frames_and_series_read_back_as_vtk_reads_them(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run([str(app("dambreak")), "--end-time", "0.05", "--frames", "2", "--out", str(out)],
                          capture_output=True)
    assert done.returncode in (0, 2)  # 2: too short a run for the front's check
    series = sparsemps.read_series(str(out / "dambreak.pvd"))
    assert len(series) == 3 and series[0][0] == 0.0 and series[2][0] == pytest.approx(0.05, rel=1e-3)
    for t, path in series:
        particles, time = sparsemps.read_frame(path)
        vtk = read_vtp(path)
        assert time == vtk["TIME"] and abs(time - t) <= 1e-6 * max(t, 1e-3)
        assert np.array_equal(particles.x, vtk["points"][:, 0]) and np.array_equal(particles.y, vtk["points"][:, 1])
        assert np.array_equal(particles.p, vtk["pressure"]) and np.array_equal(particles.kind, vtk["kind"])
    assert sparsemps.read_particles(series[-1][1]).x.size == particles.x.size
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        sparsemps.read_frame(series[0][1], dim=4)
    with pytest.raises(RuntimeError, match="cannot read the series"):
        sparsemps.read_series(str(tmp_path / "none.pvd"))


def test_particle_files_round_trip_every_bit_in_2d_and_3d(tmp_path):
    p = tank()
    p.u = np.linspace(-1, 1, p.x.size) / 3
    p.p = np.linspace(0, 1e3, p.x.size) / 7
    sparsemps.write_particles_csv(str(tmp_path / "p.csv"), p, ["made by a test"])
    assert (tmp_path / "p.csv").read_text().startswith("# made by a test\n")
    q = sparsemps.read_particles(str(tmp_path / "p.csv"))
    assert same(p, q)
    c = sparsemps.Particles3().fill_box((0, 0, 0, 0.1, 0.1, 0.1), 0.025)
    sparsemps.write_particles_csv(str(tmp_path / "c.csv"), c)
    d = sparsemps.read_particles(str(tmp_path / "c.csv"), dim=3)
    assert np.array_equal(c.positions, d.positions) and np.array_equal(c.kind, d.kind)
    (tmp_path / "bad.csv").write_text("x,y,kind\n0,0,fluid\n1,nan,fluid\n")
    with pytest.raises(RuntimeError, match=r"bad.csv:3: column 'y': 'nan' is not a finite number"):
        sparsemps.read_particles(str(tmp_path / "bad.csv"))


def test_particles_pushed_back_before_the_first_step_run_as_a_simulation_made_from_them():
    edited = tank()
    edited.v = np.where(edited.kind == 0, -0.05, 0.0)
    edited.x = edited.x + np.where(edited.kind == 0, 1e-3, 0.0)
    pushed = sparsemps.Simulation(tank(), DOMAIN, l0=0.02, fy=-9.81, dt_max=1e-3)
    pushed.particles = edited
    made = sparsemps.Simulation(edited, DOMAIN, l0=0.02, fy=-9.81, dt_max=1e-3)
    pushed.run(steps=10)
    made.run(steps=10)
    assert same(pushed.particles, made.particles)


def test_an_edit_between_steps_takes_effect_and_bad_edits_are_refused():
    sim = dambreak_simulation()
    sim.run(steps=5)
    state = sim.particles
    fluid = state.kind == 0
    state.u = np.where(fluid, state.u + 0.5, state.u)  # push the water sideways
    before = state.x.copy()
    sim.particles = state
    assert np.array_equal(sim.particles.u, state.u)
    sim.step()
    moved = sim.particles.x - before
    assert moved[fluid].mean() > 0.4 * sim.last_step.dt  # the push carried the water along
    bad = sim.particles
    bad.x = np.where(np.arange(bad.x.size) == 3, 100.0, bad.x)
    with pytest.raises(ValueError, match="particle 3 at .* is outside the domain"):
        sim.particles = bad
    fewer = sparsemps.Particles(sim.particles.x[:-1], sim.particles.y[:-1], sim.particles.kind[:-1])
    with pytest.raises(ValueError, match="in their order"):
        sim.particles = fewer
    no_fluid = sim.particles
    no_fluid.kind = np.where(no_fluid.kind == 0, 3, no_fluid.kind)
    with pytest.raises(ValueError, match="no fluid left"):
        sim.particles = no_fluid
    sim.step()  # the refusals left the run as it was


def test_every_public_name_has_a_docstring_and_a_signature_that_names_its_types():
    """help(sparsemps) documents every function, class, method and property, and no signature says `handle` or
    `object` where a type could be named (the arguments the module converts itself carry the types they take)."""
    import inspect
    import re

    undocumented, untyped = [], []
    enum_internals = {"name", "value"}

    def check(name, obj):
        doc = (getattr(obj, "__doc__", None) or "").strip()
        if not doc:
            undocumented.append(name)
        for line in doc.splitlines():
            if re.match(r"^(\d+\. )?\w+\(.*\)( -> .*)?$", line) and re.search(r"\b(handle|object)\b", line):
                untyped.append(f"{name}: {line}")

    for name, obj in vars(sparsemps).items():
        if name.startswith("_"):
            continue
        check(name, obj)
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                if (member.startswith("_") and member != "__init__") or member in enum_internals:
                    continue
                if callable(value) or isinstance(value, property):
                    check(f"{name}.{member}", value)
    assert not undocumented, undocumented
    assert not untyped, untyped
