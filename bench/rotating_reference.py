#!/usr/bin/env python3
# Reference for the rotating channel's barrel pressure symmetry (seed 000): a finite-difference solution on a polar
# grid, Stokes and Re = omega R2 (R2 - R1)/nu = 2. Usage: /usr/bin/python3 bench/rotating_reference.py [N] [--csv PATH]
# (needs python3-scipy). --csv writes the Re = 2 barrel pressure less its mean over |theta| <= 0.4, the curve
# apps/rotating/plot_rotating.py draws as the reference (bench/results/rotating_reference.csv: N = 96).
# Steady Navier-Stokes in the annular sector 1<r<2, |theta|<0.5, barrel r=2 moving at U (towards +theta), others at rest.
# Stream function-vorticity, Thom wall vorticity, Picard on the advection. Barrel pressure from the wall's
# theta-momentum: (1/r) dp/dtheta = mu domega/dr at r = R2 (the convective term vanishes on a wall sliding along itself).
import numpy as np, scipy.sparse as sp, scipy.sparse.linalg as spl, sys
def solve(N, M, U, nu, R1=1.0, R2=2.0, span=1.0, iters=60):
    r = np.linspace(R1, R2, N + 1); th = np.linspace(-span / 2, span / 2, M + 1)
    hr = r[1] - r[0]; ht = th[1] - th[0]
    n = (N + 1) * (M + 1); idx = lambda i, j: i * (M + 1) + j
    psi = np.zeros((N + 1, M + 1)); om = np.zeros_like(psi)
    for it in range(iters):
        ur = np.zeros_like(psi); ut = np.zeros_like(psi)
        ur[1:-1, 1:-1] = (psi[1:-1, 2:] - psi[1:-1, :-2]) / (2 * ht) / r[1:-1, None]
        ut[1:-1, 1:-1] = -(psi[2:, 1:-1] - psi[:-2, 1:-1]) / (2 * hr)
        rows, cols, vals = [], [], []; b = np.zeros(2 * n)
        def add(row, col, v): rows.append(row); cols.append(col); vals.append(v)
        for i in range(N + 1):
            for j in range(M + 1):
                k = idx(i, j)
                if i in (0, N) or j in (0, M):
                    add(k, k, 1.0)  # psi = 0
                    # Thom
                    kw = n + k
                    add(kw, kw, 1.0)
                    if i == N and 0 < j < M:
                        add(kw, idx(N - 1, j), 2 / hr**2); b[kw] = 2 * hr * U / hr**2 + U / R2
                    elif i == 0 and 0 < j < M:
                        add(kw, idx(1, j), 2 / hr**2)
                    elif j == 0 and 0 < i < N:
                        add(kw, idx(i, 1), 2 / (r[i] * ht)**2)
                    elif j == M and 0 < i < N:
                        add(kw, idx(i, M - 1), 2 / (r[i] * ht)**2)
                    continue
                ri = r[i]
                # Laplacian stencil coefficients
                c = {(i + 1, j): 1 / hr**2 + 1 / (2 * ri * hr), (i - 1, j): 1 / hr**2 - 1 / (2 * ri * hr),
                     (i, j + 1): 1 / (ri * ht)**2, (i, j - 1): 1 / (ri * ht)**2}
                cc = -2 / hr**2 - 2 / (ri * ht)**2
                for (a, bb), v in c.items(): add(k, idx(a, bb), v)
                add(k, k, cc); add(k, n + k, 1.0)  # lap psi + om = 0
                # nu lap om - ur dom/dr - ut/r dom/dth = 0 (central)
                kw = n + k
                a_r = ur[i, j]; a_t = ut[i, j] / ri
                for (a, bb), v in c.items(): add(kw, n + idx(a, bb), nu * v)
                add(kw, kw, nu * cc)
                add(kw, n + idx(i + 1, j), -a_r / (2 * hr)); add(kw, n + idx(i - 1, j), a_r / (2 * hr))
                add(kw, n + idx(i, j + 1), -a_t / (2 * ht)); add(kw, n + idx(i, j - 1), a_t / (2 * ht))
        A = sp.csr_matrix((vals, (rows, cols)), shape=(2 * n, 2 * n))
        x = spl.spsolve(A, b)
        new = x[:n].reshape(N + 1, M + 1)
        d = np.abs(new - psi).max(); psi = new; om = x[n:].reshape(N + 1, M + 1)
        if U == 0 or d < 1e-11 or nu == np.inf: break
    # barrel pressure: dp/dth = mu R2 dom/dr at r = R2 (one-sided, 2nd order)
    dom = (3 * om[N] - 4 * om[N - 1] + om[N - 2]) / (2 * hr)
    dp = nu * R2 * dom
    p = np.concatenate([[0], np.cumsum(0.5 * (dp[1:] + dp[:-1]) * ht)])
    return th, p
def odd(th, p, lim=0.4):
    m = np.abs(th) <= lim + 1e-12
    q = p - p[m].mean(); rng = q[m].max() - q[m].min()
    mir = np.interp(-th[m], th, q)
    return np.abs(q[m] + mir).max() / rng, rng
args = sys.argv[1:]
csv_path = args.pop(args.index("--csv") + 1) if "--csv" in args else None
args = [x for x in args if x != "--csv"]
N = int(args[0]) if args else 48
for U, nu in ((1e-6, 1.0), (2.0, 1.0)):
    th, p = solve(N, N, U, nu)
    o, rng = odd(th, p)
    print(f"N={N} U={U} nu={nu}: Re={U/nu:.3g} barrel odd defect/range over |th|<=0.4 = {o:.4f}, range {rng/U:.4g} U")
    if U == 2.0 and csv_path:
        m = np.abs(th) <= 0.4 + 1e-12
        np.savetxt(csv_path, np.c_[th, p - p[m].mean()], delimiter=",", header="phi_rad,p_minus_mean", comments="",
                   fmt="%.10g")
    if U == 2.0:
        for t, v in zip(th[::N//16], p[::N//16]): print(f"  th {t:+.3f} p {v:8.3f}")
