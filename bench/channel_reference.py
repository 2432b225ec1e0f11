"""A grid reference for the inlet channel (seed 004's set-up, docs/poiseuille.md): the same flow solved by finite
differences, to tell how far the developed parabola is from the true flow at the station at the paper's end time.

Incompressible Navier-Stokes on a staggered (MAC) grid of spacing h = D / ny over the channel [0, L] x [0, D]:
plug inflow u = U at x = 0, no-slip walls, an open outlet at x = L (p = 0, zero normal gradient of the velocity),
and plug flow everywhere at t = 0, as the particle run starts. Advection explicit (second-order upwind,
Adams-Bashforth 2), diffusion Crank-Nicolson, pressure by projection; every matrix is factorised once.

It prints, and writes as CSV, the centreline velocity at the station against time and the station profile averaged
over the last --average D/U (as the app samples it), for each grid given; compare two grids to see the error.

usage: /usr/bin/python3 bench/channel_reference.py --re 400 --ny 40,80 [--length 15] [--station 10] [--end-time 10]
           [--average 1] [--cfl 0.1] [--out runs/channel-reference]
"""
import argparse
import os
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def lap1d(n, h, low, high):
    """Second-difference matrix on n points; low/high: 'dirichlet-face' (value 0 on the face half a cell out),
    'neumann' (zero flux), 'dirichlet-node' (value 0 one cell out) or 'extrapolate' (ghost = last value)."""
    main = -2.0 * np.ones(n)
    for end, kind in ((0, low), (n - 1, high)):
        main[end] += {"dirichlet-face": -1.0, "neumann": 1.0, "dirichlet-node": 0.0, "extrapolate": 1.0}[kind]
    return sp.diags([np.ones(n - 1), main, np.ones(n - 1)], [-1, 0, 1]) / (h * h)


def sou(q, vel, axis, h, lo_pad, hi_pad):
    """vel * dq/d(axis) by second-order upwind differences; q padded by two ghost layers (lo_pad, hi_pad: arrays
    of the two ghosts on each side, nearest last/first)."""
    qp = np.concatenate([lo_pad, q, hi_pad], axis=axis)
    n = q.shape[axis]
    take = lambda s: np.take(qp, np.arange(s, s + n), axis=axis)  # noqa: E731
    back = (3 * take(2) - 4 * take(1) + take(0)) / (2 * h)
    fwd = (-3 * take(2) + 4 * take(3) - take(4)) / (2 * h)
    return np.where(vel > 0, vel * back, vel * fwd)


def solve(re, ny, length_D, station_D, end_D, average_D, cfl, D=0.2, nu=1e-6, log_every=1.0):
    U = re * nu / D
    h = D / ny
    nx = int(round(length_D * D / h))
    L = nx * h
    T = end_D * D / U
    # u on x-faces (nx+1, ny), v on y-faces (nx, ny+1), p at centres (nx, ny)
    u = np.full((nx + 1, ny), U)
    v = np.zeros((nx, ny + 1))
    # Pressure: Neumann at the inlet and the walls, p = 0 on the outlet face.
    Ap = sp.kronsum(lap1d(ny, h, "neumann", "neumann"), lap1d(nx, h, "neumann", "dirichlet-face"), format="csc")
    p_solve = spla.factorized(Ap)
    # Crank-Nicolson for the interior u (faces 1..nx: the outlet face extrapolated) and interior v (faces 1..ny-1).
    Lu = sp.kronsum(lap1d(ny, h, "dirichlet-face", "dirichlet-face"), lap1d(nx, h, "dirichlet-node", "extrapolate"),
                    format="csc")
    Lv = sp.kronsum(lap1d(ny - 1, h, "dirichlet-node", "dirichlet-node"), lap1d(nx, h, "dirichlet-face", "extrapolate"),
                    format="csc")
    # Crank-Nicolson is stable at any step; the second bound keeps the diffusion accurate (viscous number 2).
    dt = min(cfl * h / (1.5 * U), 2.0 * h * h / nu, T / 100)
    I_u, I_v = sp.identity(Lu.shape[0], format="csc"), sp.identity(Lv.shape[0], format="csc")
    u_solve = spla.factorized((I_u - 0.5 * dt * nu * Lu).tocsc())
    v_solve = spla.factorized((I_v - 0.5 * dt * nu * Lv).tocsc())
    i_station = int(round(station_D * D / h))  # the u-face at the station
    j_mid = ny // 2
    prev_adv = None
    t, step = 0.0, 0
    times, centre = [], []
    prof_sum, prof_n = np.zeros(ny), 0
    next_log = 0.0
    while t < T - 1e-9 * T:
        # Advection of u at interior faces 1..nx (nx: outlet), by u and the v interpolated to the u-faces.
        ui = u[1:, :]
        v_pad = np.concatenate([v, v[-1:, :]], axis=0)  # v beyond the outlet: zero gradient
        v_at_u = 0.25 * (v_pad[:-1, :-1] + v_pad[:-1, 1:] + v_pad[1:, :-1] + v_pad[1:, 1:])
        # x ghosts: upstream of face 1 are faces 0 (inlet, U) and -1 (U); downstream of nx: zero gradient.
        adv_u = sou(ui, ui, 0, h, np.vstack([np.full((1, ny), U), u[0:1, :]]), np.vstack([u[-1:, :], u[-1:, :]]))
        # y ghosts: no-slip, mirrored about the wall.
        adv_u += sou(ui, v_at_u, 1, h, np.hstack([-ui[:, 1:2], -ui[:, 0:1]]), np.hstack([-ui[:, -1:], -ui[:, -2:-1]]))
        # Advection of v at interior faces j = 1..ny-1.
        vi = v[:, 1:-1]
        u_at_v = 0.25 * (u[:-1, :-1] + u[1:, :-1] + u[:-1, 1:] + u[1:, 1:])
        adv_v = sou(vi, u_at_v, 0, h, np.vstack([-vi[1:2, :], -vi[0:1, :]]), np.vstack([vi[-1:, :], vi[-1:, :]]))
        adv_v += sou(vi, vi, 1, h, np.hstack([-vi[:, 0:1], np.zeros((nx, 1))]), np.hstack([np.zeros((nx, 1)), -vi[:, -1:]]))
        adv = (adv_u, adv_v)
        if prev_adv is None:
            prev_adv = adv
        # Explicit parts: AB2 advection, half the diffusion; the inlet face's U enters Lu as a Dirichlet node.
        bc_u = np.zeros_like(ui)
        bc_u[0, :] = U / (h * h)
        rhs_u = ui + dt * (-(1.5 * adv[0] - 0.5 * prev_adv[0]) + 0.5 * nu * (Lu @ ui.ravel()).reshape(ui.shape) + nu * bc_u)
        rhs_v = vi + dt * (-(1.5 * adv[1] - 0.5 * prev_adv[1]) + 0.5 * nu * (Lv @ vi.ravel()).reshape(vi.shape))
        prev_adv = adv
        u_star = u.copy()
        u_star[1:, :] = u_solve(rhs_u.ravel()).reshape(ui.shape)
        v_star = v.copy()
        v_star[:, 1:-1] = v_solve(rhs_v.ravel()).reshape(vi.shape)
        # Projection: lap phi = div u* / dt; the outlet face is corrected with p = 0 on it.
        div = (u_star[1:, :] - u_star[:-1, :]) / h + (v_star[:, 1:] - v_star[:, :-1]) / h
        phi = p_solve((div / dt).ravel()).reshape(nx, ny)
        u = u_star
        u[1:-1, :] -= dt * (phi[1:, :] - phi[:-1, :]) / h
        u[-1, :] -= dt * (0.0 - phi[-1, :]) / (0.5 * h)
        v = v_star
        v[:, 1:-1] -= dt * (phi[:, 1:] - phi[:, :-1]) / h
        t += dt
        step += 1
        times.append(t * U / D)
        centre.append(0.5 * (u[i_station, j_mid - 1] + u[i_station, j_mid]) if ny % 2 == 0 else u[i_station, j_mid])
        if t * U / D > end_D - average_D:
            prof_sum += u[i_station, :]
            prof_n += 1
        if t * U / D >= next_log:
            div_after = (u[1:, :] - u[:-1, :]) / h + (v[:, 1:] - v[:, :-1]) / h
            print(f"  Re {re:g} ny {ny}: t = {t * U / D:6.2f} D/U, step {step}, centre u at the station "
                  f"{centre[-1] / U:.4f} U, max |div u| h/U {np.abs(div_after).max() * h / U:.1e}", flush=True)
            next_log += log_every
    profile = prof_sum / max(prof_n, 1)
    y = (np.arange(ny) + 0.5) * h
    return {"h": h, "nx": nx, "steps": step, "dt": dt, "times": np.array(times), "centre": np.array(centre) / U,
            "y": y / D, "profile": profile / U, "L": L}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--re", type=float, default=400)
    ap.add_argument("--ny", default="40,80", help="grid cells across, comma-separated")
    ap.add_argument("--length", type=float, default=15.0)
    ap.add_argument("--station", type=float, default=10.0)
    ap.add_argument("--end-time", type=float, default=10.0)
    ap.add_argument("--average", type=float, default=1.0)
    ap.add_argument("--cfl", type=float, default=0.1, help="at 0.3 the upwind advection with AB2 went unstable (Re 40, D/20)")
    ap.add_argument("--out", default="runs/channel-reference")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for ny in (int(n) for n in args.ny.split(",")):
        start = time.time()
        r = solve(args.re, ny, args.length, args.station, args.end_time, args.average, args.cfl)
        # The station profile in the particle app's terms: its peak against 1.5 U.
        peak = r["profile"].max()
        q = r["profile"].mean()
        print(f"Re {args.re:g}, ny {ny} (h = D/{ny}, {r['nx']} x {ny} cells, {r['steps']} steps of {r['dt']:.3g} s, "
              f"{time.time() - start:.0f} s): station profile over the last {args.average:g} D/U: peak {peak:.4f} U "
              f"({100 * (1.5 - peak) / 1.5:+.2f} % below 1.5 U), mean {q:.4f} U", flush=True)
        stem = os.path.join(args.out, f"re{args.re:g}-ny{ny}")
        np.savetxt(stem + "-profile.csv", np.column_stack([r["y"], r["profile"]]), delimiter=",",
                   header="y_over_D,u_over_U", comments="")
        np.savetxt(stem + "-centre.csv", np.column_stack([r["times"], r["centre"]]), delimiter=",",
                   header="t_U_over_D,centre_u_over_U", comments="", fmt="%.6g")


if __name__ == "__main__":
    main()
