#!/usr/bin/python3
"""FE reference for the oscillating cantilever plate (Gray, Monaghan & Swift 2001), 2-D plane strain, linear elasticity.

Usage: /usr/bin/python3 bench/plate_reference.py   (numpy + scipy; ~1 s; writes bench/results/plate_reference.json
and bench/results/plate_reference_tip.csv, the finest mesh's tip signal).

Plate x in [0, L], y in [-H/2, H/2], L = 0.2, H = 0.02, E = 2e6, nu = 0.3975, rho = 1000, small strain, plane strain,
no gravity. Every dof on x = 0 clamped, other edges free. u(0) = 0, v_x(0) = 0, v_y(0) = V_f c0 f(x)/f(L) with V_f = 0.01,
c0 = sqrt(K/rho), K = E/(3(1-2nu)), k = 1.875104068711961/L and f the clamped-free first-mode shape (below).
Q9 elements on a uniform nx x ny mesh, 3x3 Gauss, consistent mass; 12 lowest modes by shift-invert eigsh; the tip
response u_y(L, 0, t) by modal superposition (exact in time for the discrete system, truncated to those 12 modes).
The clamped-free corners (x = 0, y = +-H/2) are stress singularities, so T1 converges only at
O(h^~1.4) (from below), not O(h^4): the Richardson order is measured, not assumed.
Compared with the Euler-Bernoulli (E' = E/(1-nu^2)) and Timoshenko clamped-free beam first-mode periods.
Import: solve(nx, ny) -> dict; tip_response(res, ...); euler_bernoulli(); timoshenko_period().
"""
import os
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # the machine is shared: keep BLAS single-threaded (must precede the numpy import)
import json, sys, time
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.linalg import expm
from scipy.optimize import brentq

L, H, E, NU, RHO = 0.2, 0.02, 2.0e6, 0.3975, 1000.0
VF = 0.01
KL = 1.875104068711961  # first root of cos(kL) cosh(kL) = -1
NMODES = 12


def lame(E=E, nu=NU):
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    return lam, mu


def c0_speed(E=E, nu=NU, rho=RHO):
    # GMS normalise V_f by the 3-D bulk sound speed, not the plane-strain one
    return np.sqrt(E / (3 * (1 - 2 * nu)) / rho)


def mode_shape(x, Lp=L):
    k = KL / Lp
    kL = KL
    return ((np.cos(kL) + np.cosh(kL)) * (np.cosh(k * x) - np.cos(k * x))
            + (np.sin(kL) - np.sinh(kL)) * (np.sinh(k * x) - np.sin(k * x)))


def _q9_element(a, b, D, rho):
    """Stiffness and consistent mass of one a x b Q9 element (local node (i,j) -> 3*j + i, i along x)."""
    g, w = np.polynomial.legendre.leggauss(3)
    N1 = lambda s: np.array([s * (s - 1) / 2, 1 - s * s, s * (s + 1) / 2])
    dN1 = lambda s: np.array([s - 0.5, -2 * s, s + 0.5])
    Ke = np.zeros((18, 18)); Me = np.zeros((18, 18))
    detJ = a * b / 4
    for xi, wx in zip(g, w):
        for eta, wy in zip(g, w):
            N = np.outer(N1(eta), N1(xi)).ravel()              # index 3*j + i
            dNdx = np.outer(N1(eta), dN1(xi)).ravel() * (2 / a)
            dNdy = np.outer(dN1(eta), N1(xi)).ravel() * (2 / b)
            B = np.zeros((3, 18))
            B[0, 0::2] = dNdx; B[1, 1::2] = dNdy
            B[2, 0::2] = dNdy; B[2, 1::2] = dNdx
            Ke += wx * wy * detJ * B.T @ D @ B
            Nm = np.zeros((2, 18)); Nm[0, 0::2] = N; Nm[1, 1::2] = N
            Me += wx * wy * detJ * rho * Nm.T @ Nm
    return Ke, Me


def assemble(nx, ny, Lp=L, Hp=H, E=E, nu=NU, rho=RHO):
    """Global (unconstrained) K, M and node coordinates; node id = gx*(2ny+1) + gy, dofs 2*id (x), 2*id+1 (y)."""
    lam, mu = lame(E, nu)
    D = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    a, b = Lp / nx, Hp / ny
    Ke, Me = _q9_element(a, b, D, rho)
    nyn = 2 * ny + 1
    ex, ey = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    ex = ex.ravel(); ey = ey.ravel()
    loc = np.array([(i, j) for j in range(3) for i in range(3)])  # local order 3*j + i
    nodes = (2 * ex[:, None] + loc[None, :, 0]) * nyn + (2 * ey[:, None] + loc[None, :, 1])
    dofs = np.empty((nodes.shape[0], 18), dtype=np.int64)
    dofs[:, 0::2] = 2 * nodes; dofs[:, 1::2] = 2 * nodes + 1
    rows = np.repeat(dofs, 18, axis=1).ravel()
    cols = np.tile(dofs, (1, 18)).ravel()
    ne = nodes.shape[0]
    ndof = 2 * (2 * nx + 1) * nyn
    # uniform mesh: every element has the same Ke, Me
    K = sp.coo_matrix((np.tile(Ke.ravel(), ne), (rows, cols)), shape=(ndof, ndof)).tocsc()
    M = sp.coo_matrix((np.tile(Me.ravel(), ne), (rows, cols)), shape=(ndof, ndof)).tocsc()
    gx, gy = np.meshgrid(np.arange(2 * nx + 1), np.arange(nyn), indexing="ij")
    xy = np.column_stack([gx.ravel() * a / 2, -Hp / 2 + gy.ravel() * b / 2])
    return K, M, xy


def rigid_body_residual(nx=8, ny=2):
    """max |K r| / max |K| for rigid translations x, y and the infinitesimal rotation, before the clamp."""
    K, M, xy = assemble(nx, ny)
    n = xy.shape[0]
    out = {}
    for name, (ux, uy) in {"tx": (np.ones(n), np.zeros(n)), "ty": (np.zeros(n), np.ones(n)),
                           "rot": (-xy[:, 1], xy[:, 0])}.items():
        r = np.empty(2 * n); r[0::2] = ux; r[1::2] = uy
        out[name] = float(np.abs(K @ r).max() / (np.abs(K).max() * np.abs(r).max()))
    return out


def solve(nx, ny, Lp=L, Hp=H, E=E, nu=NU, rho=RHO, nmodes=NMODES):
    """Modes of the clamped plate and modal initial velocities for the GMS initial condition."""
    K, M, xy = assemble(nx, ny, Lp, Hp, E, nu, rho)
    n = xy.shape[0]
    free_nodes = xy[:, 0] > 1e-12 * Lp
    free = np.empty(2 * n, dtype=bool); free[0::2] = free_nodes; free[1::2] = free_nodes
    fidx = np.flatnonzero(free)
    Kf = K[fidx][:, fidx].tocsc(); Mf = M[fidx][:, fidx].tocsc()
    lamb, phi = spl.eigsh(Kf, k=nmodes, M=Mf, sigma=0, which="LM")
    order = np.argsort(lamb); lamb = lamb[order]; phi = phi[:, order]
    phi /= np.sqrt(np.einsum("ij,ij->j", phi, Mf @ phi))  # make M-normalisation explicit
    omega = np.sqrt(lamb)
    v0 = np.zeros(2 * n)
    v0[1::2] = VF * c0_speed(E, nu, rho) * mode_shape(xy[:, 0], Lp) / mode_shape(Lp, Lp)
    v0f = v0[fidx]
    Mv0 = Mf @ v0f
    qdot = phi.T @ Mv0
    tip_node = np.flatnonzero((np.abs(xy[:, 0] - Lp) < 1e-9 * Lp) & (np.abs(xy[:, 1]) < 1e-9 * Hp))
    assert tip_node.size == 1, "no node at (L, 0)"
    tip_dof = np.flatnonzero(fidx == 2 * tip_node[0] + 1)[0]
    return {"nx": nx, "ny": ny, "omega": omega, "phi_tip": phi[tip_dof, :], "qdot": qdot,
            "ke_total": float(v0f @ Mv0), "ndof": int(fidx.size)}


def tip_response(res, t):
    """u_y(L, 0, t) = sum_i phi_i(tip) qdot_i / omega_i sin(omega_i t)."""
    amp = res["phi_tip"] * res["qdot"] / res["omega"]
    return np.sin(np.outer(t, res["omega"])) @ amp


def analyse(res, periods=5, per_period=4000):
    w = res["omega"]
    T1 = 2 * np.pi / w[0]
    t = np.linspace(0, periods * T1, periods * per_period + 1)
    u = tip_response(res, t)
    i = np.argmax(np.abs(u))
    # first local maximum, refined by a parabola through the three samples around it
    j = np.flatnonzero((u[1:-1] >= u[:-2]) & (u[1:-1] > u[2:]))[0] + 1
    y0, y1, y2 = u[j - 1], u[j], u[j + 1]
    d = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    dt = t[1] - t[0]
    t_max, u_max = t[j] + d * dt, y1 - 0.25 * (y0 - y2) * d
    # upward zero crossings; t = 0 is one (u = 0, v > 0). The window runs a quarter period past 5 T1 so that the
    # crossing near 5 T1 is not lost when higher modes shift it slightly later.
    te = np.linspace(0, (periods + 0.25) * T1, int((periods + 0.25) * per_period) + 1)
    ue = tip_response(res, te)
    k = np.flatnonzero((ue[1:-1] < 0) & (ue[2:] >= 0)) + 1
    tz = te[k] - ue[k] * (te[k + 1] - te[k]) / (ue[k + 1] - ue[k])
    tz = np.concatenate([[0.0], tz])
    T_meas = (tz[-1] - tz[0]) / (tz.size - 1)
    return {"nx": res["nx"], "ny": res["ny"], "ndof": res["ndof"],
            "omega1": float(w[0]), "omega2": float(w[1]), "omega3": float(w[2]),
            "T1": float(T1), "T2": float(2 * np.pi / w[1]), "T3": float(2 * np.pi / w[2]),
            "amplitude": float(np.abs(u[i])), "amplitude_time": float(t[i]),
            "first_max": float(u_max), "first_max_time": float(t_max),
            "period_zero_crossings": float(T_meas), "n_crossings": int(tz.size),
            "mode1_energy_fraction": float(res["qdot"][0] ** 2 / res["ke_total"]),
            "modes12_energy_fraction": float(np.sum(res["qdot"] ** 2) / res["ke_total"])}, t, u


def euler_bernoulli(Lp=L, Hp=H, E=E, nu=NU, rho=RHO):
    Ep = E / (1 - nu ** 2)
    I, A = Hp ** 3 / 12, Hp
    w = np.sqrt(Ep * I * (KL / Lp) ** 4 / (rho * A))
    return 2 * np.pi / w, VF * c0_speed(E, nu, rho) / w, w


def timoshenko_period(Lp=L, Hp=H, E=E, nu=NU, rho=RHO):
    """Clamped-free Timoshenko beam, first mode: root of the 2x2 boundary determinant of the transfer matrix.

    EI psi'' + kGA (w' - psi) + rho I om^2 psi = 0,  kGA (w'' - psi') + rho A om^2 w = 0;  state (w, w', psi, psi');
    w = psi = 0 at x = 0; moment EI psi' = 0 and shear kGA (w' - psi) = 0 at x = L. E' = E/(1-nu^2), G = mu."""
    Ep = E / (1 - nu ** 2); G = lame(E, nu)[1]
    kap = 10 * (1 + nu) / (12 + 11 * nu)
    I, A = Hp ** 3 / 12, Hp

    def det(om):
        Amat = np.array([[0, 1, 0, 0],
                         [-rho * om ** 2 / (kap * G), 0, 0, 1],
                         [0, 0, 0, 1],
                         [0, -kap * G * A / (Ep * I), kap * G * A / (Ep * I) - rho * om ** 2 / Ep, 0]])
        P = expm(Amat * Lp)
        S = P[:, [1, 3]]           # responses to unit w'(0), psi'(0)
        Bm = np.array([S[3], S[1] - S[2]])  # psi'(L), w'(L) - psi(L)
        return np.linalg.det(Bm)

    wEB = euler_bernoulli(Lp, Hp, E, nu, rho)[2]
    grid = np.linspace(0.3 * wEB, 1.2 * wEB, 400)
    vals = np.array([det(x) for x in grid])
    s = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]
    om = brentq(det, grid[s], grid[s + 1], xtol=1e-14, rtol=1e-14)
    return 2 * np.pi / om, om


def richardson(c, m, f):
    """Order from three meshes halving h, and the extrapolation from the two finest with that order."""
    p = np.log2(abs((m - c) / (f - m)))
    return float(f + (f - m) / (2 ** p - 1)), float(p)


def main():
    t0 = time.time()
    here = os.path.dirname(os.path.abspath(__file__))
    outdir = os.path.join(here, "results"); os.makedirs(outdir, exist_ok=True)
    meshes = [(20, 2), (40, 4), (80, 8), (160, 16)]
    rows = []
    for nx, ny in meshes:
        r, t, u = analyse(solve(nx, ny))
        rows.append(r)
    T_EB, A_EB, w_EB = euler_bernoulli()
    T_Ti, w_Ti = timoshenko_period()
    T1x, pT = richardson(*(r["T1"] for r in rows[-3:]))
    Ax, pA = richardson(*(r["amplitude"] for r in rows[-3:]))
    Fx, pF = richardson(*(r["first_max"] for r in rows[-3:]))

    print(f"Oscillating plate (GMS 2001), plane strain Q9: L={L} H={H} E={E:g} nu={NU} rho={RHO} V_f={VF} "
          f"c0={c0_speed():.4f} m/s")
    print(f"{'mesh':>8} {'dofs':>6} {'omega1':>9} {'T1':>9} {'T2':>9} {'T3':>9} {'amp':>9} {'t(amp)':>8} "
          f"{'1st max':>9} {'t(1st)':>8} {'T zero-x':>9} {'E1 frac':>8}")
    for r in rows:
        print(f"{r['nx']:>4}x{r['ny']:<3} {r['ndof']:>6} {r['omega1']:9.5f} {r['T1']:9.6f} {r['T2']:9.6f} "
              f"{r['T3']:9.6f} {r['amplitude']:9.6f} {r['amplitude_time']:8.5f} {r['first_max']:9.6f} "
              f"{r['first_max_time']:8.5f} {r['period_zero_crossings']:9.6f} {r['mode1_energy_fraction']:8.5f}")
    f = rows[-1]
    print(f"omega2, omega3 (finest): {f['omega2']:.4f}, {f['omega3']:.4f} rad/s;"
          f" energy in the 12 modes: {f['modes12_energy_fraction']:.6f}")
    print(f"Richardson (two finest, order from three finest): T1 = {T1x:.6f} s (p = {pT:.2f}), "
          f"amplitude = {Ax:.6f} m (p = {pA:.2f}), first max = {Fx:.6f} m (p = {pF:.2f})")
    print(f"Euler-Bernoulli (E'): T = {T_EB:.6f} s, omega = {w_EB:.5f}, amplitude V_f c0/omega = {A_EB:.6f} m")
    print(f"Timoshenko (E', G = mu, kappa = 10(1+nu)/(12+11nu), rotary inertia): T = {T_Ti:.6f} s, omega = {w_Ti:.5f}")

    out = {"parameters": {"L": L, "H": H, "E": E, "nu": NU, "rho": RHO, "V_f": VF, "c0": float(c0_speed()),
                          "kL": KL, "element": "Q9, 3x3 Gauss, consistent mass", "modes": NMODES},
           "meshes": rows,
           "extrapolated": {"T1": T1x, "T1_order": pT, "amplitude": Ax, "amplitude_order": pA,
                            "first_max": Fx, "first_max_order": pF},
           "T_EB": float(T_EB), "A_EB": float(A_EB), "T_Timoshenko": float(T_Ti)}
    with open(os.path.join(outdir, "plate_reference.json"), "w") as fh:
        json.dump(out, fh, indent=1)
    step = max(1, (t.size - 1) // 2000)  # finest mesh's signal, thinned to ~2000 rows
    np.savetxt(os.path.join(outdir, "plate_reference_tip.csv"), np.column_stack([t[::step], u[::step]]),
               delimiter=",", header="t,uy_tip", comments="", fmt="%.9e")
    print(f"wrote {outdir}/plate_reference.json, plate_reference_tip.csv  ({time.time() - t0:.1f} s)")


if __name__ == "__main__":
    sys.exit(main())
