#!/usr/bin/python3
"""The sample PPEs of data/ppe/ made afresh (scripts/make_sample_ppes.py) and checked for what the assembly
(lib/mps/numerics/ppe.cpp) must give them. SamplePpesRecreated compares channel_1e4's SHA-256 with the index: a change
detector, which a wrong matrix recorded once passes for ever. Here each small case's A and b must be:

- the index's size: as many rows as data/ppe/index.csv records unknowns, its nonzeros, b as long;
- symmetric: the file is Matrix Market `symmetric`, the lower triangle once, which mps::write_matrix_market writes
  only for an exactly symmetric A;
- an M-matrix: every diagonal entry > 0, every off-diagonal entry < 0 (-c w_ij with w > 0 for every stored pair);
- row sums: A = c (sum over the neighbours in the Laplacian sum of w) on the diagonal, -c w_ij off it, plus the
  compressibility's shift 1/(c_s dt)^2 (the channel; read from its options), so a row sums to the shift exactly (to
  round-off) unless it has a free-surface (Dirichlet) neighbour, whose weight leaves it greater; never less (weakly
  diagonally dominant). A closed domain (the screw channel) has no free surface: every row sums to 0 but the gauge's
  pinned one, whose doubled diagonal leaves it half its diagonal, and b is projected to zero mean;
- positive definite: a sparse LU with diagonal pivots only and the same permutation of rows and columns is
  P A P^T = L D L^T, and D > 0 everywhere says A is positive definite (Sylvester's law of inertia);
- nonzeros per row: on average within 10 % of the 4.1 l0 kernel's lattice neighbours plus the diagonal (49; a liquid
  keeps its lattice's density to a few %), at most the lattice points within re + l0/2 plus one (69): the lattice's
  next shells lie at 4.12 and 4.24 l0, so a little disorder brings up to 12 more neighbours in (measured: 55-57).

  tests/sample_ppes.py BUILD_DIR [NAME ...]     (default: the small cases; each is made with one thread in a scratch
                                                directory, 5-25 s)
"""
import importlib.util
import io
import math
import re
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse.linalg

SOURCE = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("make_sample_ppes", SOURCE / "scripts" / "make_sample_ppes.py")
samples = importlib.util.module_from_spec(spec)
spec.loader.exec_module(samples)

CLOSED = {"screw_1e4", "screw_1e5"}  # closed domains: the gauge, no free surface
ROUND_OFF = 1e-12                    # of a row's diagonal: a row sum of ~50 terms
failures = []


def check(name, condition, what):
    print(f"{'ok  ' if condition else 'FAIL'} {name}: {what}")
    if not condition:
        failures.append(f"{name}: {what}")


def header(text):
    """(dt, re in l0, rho) from the exporter's header comments."""
    head = text[:2000].decode()
    dt = float(re.search(r"dt = (\S+) s", head).group(1))
    radius = float(re.search(r"Laplacian radius = (\S+) l0", head).group(1))
    rho = float(re.search(r"rho = (\S+) kg/m\^3", head).group(1))
    return dt, radius, rho


def compressibility_shift(name, dt, rho):
    """1/(c dt)^2 of the poiseuille app's inlet channel (Params::sound_speed), from the case's options; 0 otherwise."""
    app = samples.CASES[name][0]
    options = tomllib.loads((samples.DATA / f"{name}.toml").read_text())
    if app != "poiseuille" or options.get("mode") != "inlet" or options.get("compression", 0) <= 0:
        return 0.0
    D, nu = options["width"], options["nu"]
    U = options["re"] * nu / D
    drop = 12.0 * rho * nu * U * options["channel-length"] * D / (D * D)
    c = math.sqrt(max((1.5 * U) ** 2, drop / rho) / options["compression"])
    return 1.0 / (c * dt) ** 2


def lattice_points(radius):
    n = math.ceil(radius)
    return sum(1 for i in range(-n, n + 1) for j in range(-n, n + 1) if 0 < i * i + j * j < radius * radius)


def check_case(name, expected, a_text, b_text):
    dt, radius, rho = header(a_text)
    banner = a_text.split(b"\n", 1)[0].decode()
    check(name, banner == "%%MatrixMarket matrix coordinate real symmetric", f"stored as symmetric ({banner})")
    lines = a_text.split(b"\n")
    first = next(k for k, line in enumerate(lines) if not line.startswith(b"%"))
    n, cols, stored = map(int, lines[first].split())
    at = np.loadtxt(io.BytesIO(b"\n".join(lines[first + 1:])), usecols=(0, 1), dtype=np.int64, ndmin=2)
    unique = np.unique(at[:, 0] * (n + 1) + at[:, 1]).size
    check(name, at.shape[0] == stored == unique and (at[:, 0] >= at[:, 1]).all(),
          f"the lower triangle only, each entry once ({stored} stored)")
    a = scipy.io.mmread(io.BytesIO(a_text)).tocsr()  # both triangles
    b = np.asarray(scipy.io.mmread(io.BytesIO(b_text))).ravel()
    check(name, a.shape == (n, n) and cols == n and n == int(expected["unknowns"]),
          f"{n} rows, the index's {expected['unknowns']} unknowns")
    check(name, a.nnz == int(expected["nonzeros"]), f"{a.nnz} nonzeros, the index's {expected['nonzeros']}")
    check(name, b.size == n, f"b has {b.size} entries")

    diagonal = a.diagonal()
    off = a.copy()
    off.setdiag(0.0)
    off.eliminate_zeros()
    check(name, (diagonal > 0).all(), f"every diagonal entry > 0 (smallest {diagonal.min():.4g})")
    check(name, (off.data < 0).all() and off.nnz == a.nnz - n,
          f"every off-diagonal entry < 0 (largest {off.data.max():.3g})")

    sums = np.asarray(a.sum(axis=1)).ravel()
    shift = compressibility_shift(name, dt, rho)
    excess = (sums - shift) / diagonal
    at_shift = np.abs(excess) <= ROUND_OFF
    check(name, (excess >= -ROUND_OFF).all(),
          f"every row sums to >= the shift {shift:.6g} (weakly diagonally dominant; lowest {excess.min():.2e} of its "
          "diagonal below it)")
    if name in CLOSED:
        pinned = np.flatnonzero(~at_shift)
        check(name, pinned.size == 1 and abs(excess[pinned[0]] - 0.5) <= ROUND_OFF,
              f"every row sums to 0 but one, which sums to half its diagonal (the gauge's pin): {pinned.size} rows "
              f"off 0, excess {excess[pinned].max() if pinned.size else 0:.12g}")
        check(name, abs(b.sum()) <= ROUND_OFF * np.abs(b).sum(),
              f"b sums to 0 ({b.sum():.3g} of {np.abs(b).sum():.3g})")
    else:
        check(name, at_shift.sum() > n // 2 and (~at_shift).sum() > 0,
              f"rows without a free-surface neighbour sum to the shift exactly ({at_shift.sum()} rows), the others to "
              f"more ({(~at_shift).sum()} rows, up to {excess.max():.3f} of their diagonal)")

    lu = scipy.sparse.linalg.splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                  options=dict(SymmetricMode=True))
    pivots = lu.U.diagonal()
    check(name, np.array_equal(lu.perm_r, lu.perm_c) and (pivots > 0).all(),
          f"positive definite: L D L^T with diagonal pivots, smallest pivot {pivots.min():.4g}")

    per_row = np.diff(a.indptr)
    lattice = lattice_points(radius) + 1
    check(name, abs(per_row.mean() / lattice - 1.0) <= 0.1 and per_row.max() <= lattice_points(radius + 0.5) + 1,
          f"nonzeros per row {per_row.mean():.1f} on average (lattice {lattice}), {per_row.min()}-{per_row.max()} "
          f"(at most {lattice_points(radius + 0.5) + 1})")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    build = sys.argv[1]
    names = sys.argv[2:] or samples.GROUPS["small"]
    index = samples.read_index()
    for name in names:
        with tempfile.TemporaryDirectory() as scratch:
            _, a_text, b_text = samples.make(build, name, scratch)
        check_case(name, index[f"{name}.mtx.gz"], a_text, b_text)
    if failures:
        print(f"{len(failures)} checks failed:\n  " + "\n  ".join(failures))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
