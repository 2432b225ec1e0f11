"""PPE assembly from particle arrays: bitwise the system the C++ step assembles (the dambreak app's --export-ppe and
the step of a Simulation), symmetric positive definite, and its pressures those of the step."""
import numpy as np
import pytest
import scipy.io
import scipy.sparse

import sparsemps
from conftest import dambreak_scene, dambreak_simulation

G = 9.81


def assert_same_system(ppe_matrix, ppe_rhs, a, b):
    """Bitwise: the same CSR arrays (rows sorted, same pattern) and the same values, to the last bit."""
    a = scipy.sparse.csr_matrix(a)
    a.sort_indices()
    assert ppe_matrix.shape == a.shape
    assert np.array_equal(ppe_matrix.indptr, a.indptr) and np.array_equal(ppe_matrix.indices, a.indices)
    assert np.array_equal(ppe_matrix.data, a.data)
    assert np.array_equal(ppe_rhs, b)


def test_assembled_ppe_equals_the_dambreak_apps_first_step_bitwise(dambreak_run):
    particles, _, config = dambreak_scene()
    # The app's step 1 ran on its particles reordered by cell; one step of the same simulation tells that order
    # (ids), and its dt. At step 1 the column is at rest and the body force is split off, so r* = r and u* = 0.
    sim = dambreak_simulation()
    sim.step()
    order, dt = sim.particles.id, sim.last_step.dt
    ppe = sparsemps.assemble_ppe(particles.x[order], particles.y[order], particles.u[order], particles.v[order],
                                 particles.kind[order], dt=dt, config=config)
    a = scipy.io.mmread(dambreak_run / "ppe" / "step_000001.mtx")
    b = np.asarray(scipy.io.mmread(dambreak_run / "ppe" / "step_000001_rhs.mtx")).ravel()
    assert_same_system(ppe.matrix, ppe.rhs, a, b)
    # In the particles' own order the same system with its unknowns renumbered, to round-off: the sums over
    # neighbours run in another order.
    unordered = sparsemps.assemble_ppe(particles, dt=dt, config=config)
    back = np.argsort(order)  # original index -> position in the step's order
    perm = ppe.unknown[back][unordered.particle]  # unordered unknown -> step-order unknown
    a_perm = ppe.matrix.toarray()[np.ix_(perm, perm)]
    assert np.array_equal(unordered.matrix.toarray() != 0, a_perm != 0)
    assert np.abs(unordered.matrix.toarray() - a_perm).max() < 1e-12 * np.abs(a_perm).max()
    assert np.abs(unordered.rhs - ppe.rhs[perm]).max() < 1e-12 * np.abs(ppe.rhs).max()


def swirl_tank():
    """A tank of fluid with a swirling velocity field: the divergence part of the source is not zero."""
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.2, 0.2), 0.01).add_rectangle_walls((0, 0, 0.2, 0.3), 0.01)
    fluid = p.kind == sparsemps.Kind.fluid.value
    k = np.pi / 0.2
    p.u = np.where(fluid, 0.1 * np.sin(k * p.x) * np.cos(k * p.y) + 0.02 * p.x, 0.0)
    p.v = np.where(fluid, -0.1 * np.cos(k * p.x) * np.sin(k * p.y), 0.0)
    return p


@pytest.mark.parametrize("gamma", [0.01, 0.5, 0.99])
def test_assembled_ppe_equals_the_step_of_a_simulation_for_moving_particles(gamma):
    p = swirl_tank()
    # Without viscosity and body force the predictor gives u* = u and r* = r + dt u, which NumPy computes alike.
    config = dict(l0=0.01, nu=0.0, dt_max=1e-3, gamma=gamma, reorder_every=0)
    sim = sparsemps.Simulation(p, (-0.1, 0.3, -0.1, 0.4), config)
    sim.step()
    dt = sim.last_step.dt
    ppe = sparsemps.assemble_ppe(p.x + dt * p.u, p.y + dt * p.v, p.u, p.v, p.kind, dt=dt, config=config)
    step = sim.last_ppe
    assert_same_system(ppe.matrix, ppe.rhs, step.matrix, step.rhs)
    for field in ["unknown", "particle", "free_surface", "number_density", "divergence", "source"]:
        assert np.array_equal(getattr(ppe, field), getattr(step, field)), field
    assert np.abs(ppe.divergence[p.kind == 0]).max() > 0.1  # the velocities did enter


def test_assembled_ppe_equals_the_step_across_a_periodic_boundary():
    # A channel periodic in x, walls below and above, the fluid carried across x = 0.2 within the step.
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.2, 0.1), 0.01)
    p.add_rectangle_walls((0, 0, 0.2, 0.1), 0.01, sides="bottom|top")
    fluid = p.kind == 0
    p.u = np.where(fluid, 2.0 + np.sin(10 * np.pi * p.y), 0.0)
    domain = sparsemps.Domain(0, 0.2, -0.06, 0.16, periodic_x=True)
    config = dict(l0=0.01, nu=0.0, dt_max=2e-3, reorder_every=0, cfl=1.0, max_displacement=1.0)
    sim = sparsemps.Simulation(p, domain, config)
    sim.step()
    dt = sim.last_step.dt
    x_star = p.x + dt * p.u
    assert x_star.max() > 0.2  # given unwrapped, wrapped as the predictor wraps
    ppe = sparsemps.assemble_ppe(x_star, p.y, p.u, p.v, p.kind, dt=dt, domain=domain, config=config)
    assert_same_system(ppe.matrix, ppe.rhs, sim.last_ppe.matrix, sim.last_ppe.rhs)
    assert ppe.matrix.shape[0] == 240 and ppe.floating_groups == 1  # 200 fluid, 2 x 20 wall: sealed
    assert np.abs(ppe.divergence[fluid]).max() > 1.0


def test_assembled_ppe_is_symmetric_positive_definite_over_the_wet_particles():
    particles, _, config = dambreak_scene()
    ppe = sparsemps.assemble_ppe(particles, dt=1e-3, config=config)
    a = ppe.matrix
    assert (a != a.T).nnz == 0  # exactly symmetric
    np.linalg.cholesky(a.toarray())  # raises LinAlgError unless positive definite
    assert np.linalg.eigvalsh(a.toarray())[0] > 0
    kind = particles.kind
    # Unknowns: fluid and wall particles off the free surface, numbered in particle order; the rest -1.
    wet = (kind <= 1) & ~ppe.free_surface
    assert np.array_equal(ppe.unknown >= 0, wet)
    assert np.array_equal(ppe.particle, np.flatnonzero(wet))
    assert np.array_equal(ppe.unknown[ppe.particle], np.arange(a.shape[0]))
    assert ppe.free_surface[kind == sparsemps.Kind.dummy.value].sum() == 0
    assert ppe.free_surface[kind == 0].sum() > 0


def test_pressures_of_a_tank_at_rest_are_hydrostatic():
    l0, h = 0.01, 0.2
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.2, h), l0).add_rectangle_walls((0, 0, 0.2, 1.2 * h), l0)
    ppe = sparsemps.assemble_ppe(p, dt=1e-3, l0=l0, fy=-G)
    # The split solves for P - rho f.r, the surface held at rho g l0/2: P' is constant, P exactly rho g (H - y).
    assert np.array_equal(ppe.offset, 1000.0 * (-G * p.y))
    x, _ = sparsemps.solve(ppe.matrix, ppe.rhs, "cholmod")
    pressure = ppe.pressures(x)
    fluid = p.kind == 0
    exact = 1000.0 * G * (h - p.y)
    assert np.abs(pressure[fluid] - exact[fluid]).max() < 1e-6 * exact.max()  # measured: 3.4e-9 Pa of 1962
    assert np.all(pressure[p.kind == sparsemps.Kind.dummy.value] == 0)  # dummies are the step's to set


def sealed_box():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01)
    return p.add_rectangle_walls((0, 0, 0.1, 0.1), 0.01, sides="left|right|bottom|top")


def test_closed_box_gets_the_gauge_and_its_pressure_solves_the_singular_ppe():
    p = sealed_box()
    p.u = np.where(p.kind == 0, 0.01 * p.y, 0.0)  # a shear the walls stop: div u* is not zero along them
    ppe = sparsemps.assemble_ppe(p.x, p.y, p.u, p.v, p.kind, dt=1e-3, l0=0.01, fy=-G)
    assert ppe.floating_groups == 1 and not ppe.free_surface.any()
    a, b = ppe.matrix, ppe.rhs
    n, eps = a.shape[0], np.finfo(float).eps
    # The gauge (lib/mps/numerics/ppe.hpp): the lowest unknown's diagonal doubled, the mean of b removed. Undoing the first gives
    # the all-Neumann Laplacian L, whose rows sum to 0 (each row ~50 terms rounded at eps max|A|: 1e-13 bounds it).
    laplacian = a.tolil()
    laplacian[0, 0] /= 2
    laplacian = laplacian.tocsr()
    assert np.abs(laplacian @ np.ones(n)).max() <= 1e-13 * np.abs(a).max()
    assert abs(b.sum()) <= n * eps * np.abs(b).sum()  # consistent: b in the range of L
    exact = None
    for spec in ["cholmod", "eigen-cg:tol=1e-10"]:
        x, report = sparsemps.solve(a, b, spec)
        residual = np.linalg.norm(a @ x - b)
        # L x - b = (A x - b) - d x_0 e_0, and summing A x - b over the rows gives d x_0 = sum(A x - b) + sum(b): the
        # pinned unknown sits at 0 and x solves the PPE's own rows, each to what the solve's residual allows.
        assert laplacian[0, 0] * abs(x[0]) <= np.sqrt(n) * residual + abs(b.sum())
        assert np.linalg.norm(laplacian @ x - b) <= (1 + np.sqrt(n)) * residual + abs(b.sum())
        relative = (ppe.pressures(x) - ppe.offset)[ppe.particle]  # the unknown P - rho f.r, shifted to zero mean
        assert abs(relative.mean()) <= n * eps * np.abs(relative).max()  # n terms, each rounded at eps max
        assert np.abs(relative).max() > 0.1  # measured: 0.35 Pa
        if exact is None:
            exact = relative
        else:  # |x - x*| / |x*| <= cond(A) |b - A x| / |b|: the gauge picks one solution whatever the solver
            eigenvalues = np.linalg.eigvalsh(a.toarray())
            bound = eigenvalues[-1] / eigenvalues[0] * report.relative_residual
            assert np.linalg.norm(relative - exact) <= bound * np.linalg.norm(exact)  # measured 8.7e-12, bound 4.5e-8


def test_closed_box_at_rest_is_hydrostatic_at_the_gauges_level():
    p = sealed_box()
    ppe = sparsemps.assemble_ppe(p, dt=1e-3, l0=0.01, fy=-G)
    x, _ = sparsemps.solve(ppe.matrix, ppe.rhs, "cholmod")
    # At rest b is only the round-off of n* - n0, so |x| <= |b| / lambda_min(A): P - rho f.r is the gauge's constant,
    # 0, and P = -rho g y up to that and the rounding of P = x + offset (measured 1e-10 Pa against 8e-8).
    wet = ppe.particle
    rounding = 4 * np.finfo(float).eps * np.abs(ppe.offset[wet]).max()
    bound = np.linalg.norm(ppe.rhs) / np.linalg.eigvalsh(ppe.matrix.toarray())[0] + rounding
    assert np.abs(ppe.pressures(x)[wet] - 1000.0 * (-G) * p.y[wet]).max() <= bound


def test_bad_particles_raise_clear_errors():
    with pytest.raises(ValueError, match=r"kind\[1\] = 7 is not 0-3"):
        sparsemps.assemble_ppe([0.0, 0.01], [0.0, 0.0], [0, 0], [0, 0], [0, 7], dt=1e-3, l0=0.01)
    with pytest.raises(ValueError, match=r"y has length 3, expected 2"):
        sparsemps.assemble_ppe([0.0, 0.01], [0.0, 0.0, 0.0], [0, 0], [0, 0], [0, 0], dt=1e-3, l0=0.01)
    with pytest.raises(ValueError, match=r"x\[1\] is nan: every entry must be a finite number"):
        sparsemps.assemble_ppe([0.0, np.nan], [0.0, 0.0], [0, 0], [0, 0], [0, 0], dt=1e-3, l0=0.01)
    with pytest.raises(ValueError, match=r"dt must be positive"):
        sparsemps.assemble_ppe([0.0], [0.0], [0], [0], [0], dt=0.0, l0=0.01)
    with pytest.raises(ValueError, match=r"l0 must be positive \(in m\), got 0"):
        sparsemps.assemble_ppe([0.0], [0.0], [0], [0], [0], dt=1e-3)
    with pytest.raises(ValueError, match=r"no field 'gama'"):
        sparsemps.assemble_ppe([0.0], [0.0], [0], [0], [0], dt=1e-3, l0=0.01, gama=0.5)
    # 0 switches the asymmetry test off; NaN and negative fractions used to switch it off silently too.
    for bad in [np.nan, -1.0]:
        with pytest.raises(ValueError, match=rf"^asymmetry fraction must be in \(0, 10\], got {bad:f}$"):
            sparsemps.assemble_ppe([0.0], [0.0], [0], [0], [0], dt=1e-3, l0=0.01, asymmetry=bad)
    ppe = sparsemps.assemble_ppe(sealed_box(), dt=1e-3, l0=0.01)
    with pytest.raises(ValueError, match=r"^x\[0\] is nan: every entry must be a finite number$"):
        ppe.pressures(np.full(ppe.matrix.shape[0], np.nan))  # used to scatter NaN pressures


def test_kernel_radii_outside_one_to_ten_spacings_are_refused():
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.2, 0.2), 0.02)
    # 1e6 l0 used to hang in the kernel's lattice sum for n0 and lambda.
    with pytest.raises(ValueError, match=r"radius_laplacian must be in \(1, 10\] \(in l0\), got 1e\+06"):
        sparsemps.assemble_ppe(p, dt=1e-3, l0=0.02, radius_laplacian=1e6)
    for field in ["radius_density", "radius_surface", "radius_gradient", "radius_laplacian"]:
        for bad in [10.5, 1.0, np.inf, np.nan]:
            with pytest.raises(ValueError, match=rf"{field} must be in \(1, 10\] \(in l0\), got {bad:g}"):
                sparsemps.Simulation(p, (-1, 1, -1, 1), l0=0.02, dt_max=1e-3, **{field: bad})
        with pytest.raises(ValueError, match=rf"{field} must be in \(1, 10\]"):
            sparsemps.SimulationConfig(l0=0.02, dt_max=1e-3, **{field: 11.0}).validate()
    widest = sparsemps.assemble_ppe(p, dt=1e-3, l0=0.02, radius_laplacian=10.0)  # the range's end is taken
    assert widest.matrix.shape[0] > 0


def test_nan_velocities_and_coincident_particles_are_refused_not_assembled():
    # Both used to give a right-hand side holding NaN.
    p = sparsemps.Particles().fill_rectangle((0, 0, 0.1, 0.1), 0.01).add_rectangle_walls((0, 0, 0.1, 0.2), 0.01)
    for name, bad in [("u", np.nan), ("v", np.inf), ("y", -np.inf)]:
        arrays = {k: getattr(p, k) for k in "xyuv"}
        arrays[name][3] = bad
        with pytest.raises(ValueError, match=rf"^{name}\[3\] is {bad!r}: every entry must be a finite number$"):
            sparsemps.assemble_ppe(arrays["x"], arrays["y"], arrays["u"], arrays["v"], p.kind, dt=1e-3, l0=0.01)
    x, y = p.x, p.y
    x[:50], y[:50] = 0.05, 0.05
    with pytest.raises(ValueError, match=r"^simulation: particles 0 and 1 sit at one position \(0.05, 0.05\), "
                                         r"closer than 1e-06 l0; remove or move one of them$"):
        sparsemps.assemble_ppe(x, y, p.u, p.v, p.kind, dt=1e-3, l0=0.01)
    # A ghost is inactive: it may sit where an active particle is.
    kind = p.kind
    kind[1:50] = sparsemps.Kind.ghost.value
    ppe = sparsemps.assemble_ppe(x, y, p.u, p.v, kind, dt=1e-3, l0=0.01)
    assert np.isfinite(ppe.rhs).all() and np.isfinite(ppe.matrix.data).all()
