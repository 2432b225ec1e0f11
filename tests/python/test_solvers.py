"""The solver registry from Python: every backend on the sample PPEs of data/, against SciPy and CHOLMOD; state kept
between solves; bad input raising with the library's message."""
import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.linalg

import sparsemps
from conftest import SAMPLES, load_sample

BACKENDS = ["auto", "eigen-cg", "eigen-bicgstab", "cholmod", "hypre-amg", "hypre-pcg", "petsc"]
# Every backend and preconditioner, at a tolerance tighter than the default so that agreement is tested closely.
SPECS = ["auto:tol=1e-10", "eigen-cg:tol=1e-10", "eigen-cg:precond=jacobi,tol=1e-10", "eigen-bicgstab:tol=1e-10",
         "eigen-bicgstab:precond=jacobi,tol=1e-10", "hypre-amg:tol=1e-10", "hypre-pcg:tol=1e-10",
         "hypre-pcg:filter=0.2,tol=1e-10", "petsc:tol=1e-10", "petsc:pc_type=hypre,tol=1e-10"]


def relative(x, reference):
    return np.linalg.norm(x - reference) / np.linalg.norm(reference)


def test_registry_lists_every_backend_with_its_keys_and_defaults():
    listed = sparsemps.solvers()
    assert [s["name"] for s in listed] == sparsemps.solver_names() == BACKENDS
    for entry in listed:
        assert entry["summary"] and entry["keys"]
        spec = sparsemps.Solver(entry["name"]).spec  # every key spelled out with its value
        assert spec.startswith(entry["name"] + ":")
        assert dict(item.split("=") for item in spec.split(":", 1)[1].split(",")) == {
            key: value["default"] for key, value in entry["keys"].items()}
    assert "hypre-pcg" in sparsemps.describe_solvers()


@pytest.mark.parametrize("name", SAMPLES)
def test_cholmod_from_python_matches_scipy_spsolve(name):
    a, b = load_sample(name)
    x, report = sparsemps.solve(a, b, "cholmod")
    reference = scipy.sparse.linalg.spsolve(a.tocsc(), b)
    assert report.backend == "cholmod" and report.iterations == 1
    assert relative(x, reference) < 1e-12  # measured: 2.4e-15 to 6.1e-15


@pytest.mark.parametrize("name", SAMPLES)
@pytest.mark.parametrize("spec", SPECS)
def test_every_backend_agrees_with_cholmod_within_its_residual(name, spec):
    a, b = load_sample(name)
    exact, _ = sparsemps.solve(a, b, "cholmod")
    x, report = sparsemps.solve(a, b, spec)
    residual = np.linalg.norm(b - a @ x) / np.linalg.norm(b)
    # The report's residual is that of the returned x, and below the tolerance asked for.
    assert report.relative_residual == pytest.approx(residual, rel=1e-6)
    assert residual <= 1e-10
    assert report.iterations > 0 and report.backend == spec.split(":")[0].replace("auto", "eigen-cg")
    # |x - x*| / |x*| <= cond(A) |b - A x| / |b|: the error an SPD solve at that residual may have, no more.
    eigenvalues = np.linalg.eigvalsh(a.toarray())
    condition = eigenvalues[-1] / eigenvalues[0]
    assert relative(x, exact) <= condition * residual  # measured: 4.5e-13 to 4.9e-9 against bounds 3e-10 to 9e-8


def test_default_spec_solves_to_its_tolerance():
    a, b = load_sample("ppe_tank_re4.1")
    x, report = sparsemps.solve(a, b)
    assert report.relative_residual <= 1e-8
    assert relative(x, scipy.sparse.linalg.spsolve(a.tocsc(), b)) < 1e-6


def test_hypre_keeps_its_hierarchy_across_solves_of_one_solver_object():
    a, b = load_sample("ppe_tank_re3.1")
    solver = sparsemps.Solver("hypre-pcg:reuse=2")
    assert "reuse=2" in solver.spec and repr(solver) == f"Solver('{solver.spec}')"
    x1, first = solver.solve(a, b)
    x2, second = solver.solve(a, 2 * b)
    x3, third = solver.solve(a, 3 * b)
    fourth = solver.solve(a, b)[1]
    assert not first.setup_reused and second.setup_reused and third.setup_reused
    assert not fourth.setup_reused  # the two reuses spent, a fresh setup
    assert relative(x2, 2 * x1) < 1e-7 and relative(x3, 3 * x1) < 1e-7
    # One residual per iteration from the initial guess on.
    assert len(first.residual_history) == first.iterations + 1


def test_initial_guess_is_passed_to_the_solver():
    a, b = load_sample("ppe_tank_re4.1")
    exact, _ = sparsemps.solve(a, b, "cholmod")
    x, report = sparsemps.solve(a, b, "eigen-cg", x0=exact)
    assert report.iterations == 0 and np.array_equal(x, exact)
    assert sparsemps.solve(a, b, "eigen-cg")[1].iterations > 5


def test_any_csr_convertible_matrix_gives_the_same_solution():
    a, b = load_sample("ppe_tank_re4.1")
    x, _ = sparsemps.solve(a, b, "eigen-cg")
    # The same matrix with int64 indices, shuffled columns and one entry split in two.
    coo = a.tocoo()
    order = np.random.default_rng(1).permutation(coo.nnz)
    rows, cols, vals = coo.row[order], coo.col[order], coo.data[order].copy()
    half = vals[0] / 2
    rows, cols, vals = np.append(rows, rows[0]), np.append(cols, cols[0]), np.append(vals, half)
    vals[0] = half
    messy = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=a.shape)
    messy.indices = messy.indices.astype(np.int64)
    messy.indptr = messy.indptr.astype(np.int64)
    unsorted = scipy.sparse.csr_matrix((a.data[::-1].copy(), a.indices[::-1].copy(), a.indptr.copy()), shape=a.shape)
    for r in range(a.shape[0]):  # each row's entries reversed: a valid CSR matrix whose columns descend
        s, e = a.indptr[r], a.indptr[r + 1]
        unsorted.data[s:e] = a.data[s:e][::-1]
        unsorted.indices[s:e] = a.indices[s:e][::-1]
    unsorted.has_sorted_indices = False
    for variant in [coo, a.tocsc(), scipy.sparse.csr_array(a), a.toarray(), messy, unsorted]:
        xv, _ = sparsemps.solve(variant, b, "eigen-cg")
        assert np.allclose(xv, x, rtol=1e-13, atol=0)
    assert not np.all(np.diff(unsorted.indices[unsorted.indptr[0]:unsorted.indptr[1]]) > 0)  # left as it was


def test_failed_solve_raises_solver_error_with_its_report():
    a, b = load_sample("ppe_tank_re4.1")
    with pytest.raises(sparsemps.SolverError, match=r"no convergence after 2 of max_iter 2") as caught:
        sparsemps.solve(a, b, "eigen-cg:max_iter=2")
    assert isinstance(caught.value, RuntimeError)
    assert caught.value.report.iterations == 2 and caught.value.report.relative_residual > 1e-8


def nonsymmetric(a):
    m = a.tolil()
    m[0, 1] = m[0, 1] + 1.0
    return m.tocsr()


def with_nan(a):
    m = a.copy()
    m.data[5] = np.nan
    return m


@pytest.mark.parametrize("make, error, message", [
    (lambda a, b: sparsemps.Solver("hypre-pcg:tolerance=1"), ValueError,
     r"solver 'hypre-pcg' has no key 'tolerance'; valid keys: tol, max_iter"),
    (lambda a, b: sparsemps.Solver("amg"), ValueError, r"unknown solver 'amg'; valid solvers: auto, eigen-cg"),
    (lambda a, b: sparsemps.Solver("eigen-cg:tol=abc"), ValueError, r"tol=abc is not a number"),
    (lambda a, b: sparsemps.Solver("eigen-cg:tol=1e-8,tol=1e-9"), ValueError, r"sets 'tol' twice"),
    (lambda a, b: sparsemps.solve(a, b[:-1]), sparsemps.SolverError,
     r"matrix and vector sizes do not match \(matrix 416 x 416, b 415"),
    (lambda a, b: sparsemps.solve(a[:, :-1], b[:-1]), sparsemps.SolverError, r"matrix 416 x 415"),
    (lambda a, b: sparsemps.solve(a, b, x0=np.zeros(3)), ValueError, r"x0 has length 3, expected 416"),
    (lambda a, b: sparsemps.solve(a, b.reshape(-1, 1)), ValueError,
     r"b must be a 1-D array of A's size \(416 entries\), got shape \(416, 1\)"),
    (lambda a, b: sparsemps.solve(a, 1.0), ValueError,
     r"b must be a 1-D array of A's size \(416 entries\), got a scalar"),
    (lambda a, b: sparsemps.solve(a, b, x0=[[0.0]]), ValueError, r"x0 must be 1-D, got shape \(1, 1\)"),
    (lambda a, b: sparsemps.solve(a, b.astype(complex)), TypeError, r"b must hold real numbers, got dtype complex128"),
    (lambda a, b: sparsemps.solve("matrix", b), TypeError, r"A must be a scipy.sparse matrix or convertible"),
    (lambda a, b: sparsemps.solve(with_nan(a), b), sparsemps.SolverError, r"eigen-cg: NaN or Inf in the matrix"),
    (lambda a, b: sparsemps.solve(a, np.where(np.arange(len(b)) == 0, np.inf, b), "cholmod"), sparsemps.SolverError,
     r"cholmod: NaN or Inf in the right-hand side"),
    (lambda a, b: sparsemps.solve(-a, b, "cholmod"), sparsemps.SolverError, r"not positive definite"),
    (lambda a, b: sparsemps.solve(nonsymmetric(a), b, "hypre-pcg"), sparsemps.SolverError, r"not symmetric"),
])
def test_bad_input_raises_with_the_library_message(make, error, message):
    a, b = load_sample("ppe_tank_re4.1")
    with pytest.raises(error, match=message):
        make(a, b)


def small_spd():
    """A 10 x 10 CSR with 30 random entries plus 10 on the diagonal (the matrix of issue 36's crash, made definite)."""
    return (scipy.sparse.random(10, 10, density=0.3, random_state=1) + 10 * scipy.sparse.eye(10)).tocsr()


def damaged(change, fmt="csr"):
    m = small_spd().asformat(fmt)
    change(m)
    return m


def set_item(name, index, value):
    return lambda m: getattr(m, name).__setitem__(index, value)


def set_attr(name, value):
    return lambda m: setattr(m, name, value(getattr(m, name)))


# SciPy's own conversions trust these arrays (a damaged indptr used to abort the interpreter in sum_duplicates), so
# each must be refused before SciPy touches the matrix, naming the array and the entry.
@pytest.mark.parametrize("matrix, message", [
    (damaged(set_item("indptr", 2, 100)), r"A \(csr\): indptr\[2\] = 100 is beyond the 38 stored indices"),
    (damaged(set_item("indptr", 3, 1)), r"A \(csr\): indptr decreases from indptr\[2\] = \d+ to indptr\[3\] = 1"),
    (damaged(set_item("indptr", 0, 1)), r"A \(csr\): indptr starts at 1, not 0"),
    (damaged(set_item("indptr", -1, 37)), r"A \(csr\): indptr ends at 37 but 38 indices are stored"),
    (damaged(set_attr("indptr", lambda v: v[:-1])), r"A \(csr\): indptr has 10 entries, expected rows \+ 1 = 11"),
    (damaged(set_item("indices", 5, 10)), r"A \(csr\): indices\[5\] = 10 is outside \[0, 10\)"),
    (damaged(set_item("indices", 0, -1)), r"A \(csr\): indices\[0\] = -1 is outside \[0, 10\)"),
    (damaged(set_attr("indices", lambda v: v.astype(float))), r"A \(csr\): indices must be an array of integers"),
    (damaged(set_attr("data", lambda v: v[:-1])), r"A \(csr\): data holds 37 values but indices 38"),
    (damaged(set_attr("data", lambda v: v.reshape(-1, 1))), r"A \(csr\): data must be a 1-D array"),
    (damaged(set_attr("_shape", lambda s: (11, 10))), r"A \(csr\): indptr has 11 entries, expected rows \+ 1 = 12"),
    (damaged(set_item("indptr", 2, 100), "csc"), r"A \(csc\): indptr\[2\] = 100 is beyond the 38 stored indices"),
    (damaged(set_item("indices", 0, 99), "csc"), r"A \(csc\): indices\[0\] = 99 is outside \[0, 10\)"),
    (damaged(set_item("indices", 0, 99), "bsr"), r"A \(bsr\): indices\[0\] = 99 is outside \[0, 10\)"),
    (damaged(set_item("row", 0, 10), "coo"), r"A \(coo\): row\[0\] = 10 is outside \[0, 10\)"),
    (damaged(set_item("col", 3, -2), "coo"), r"A \(coo\): col\[3\] = -2 is outside \[0, 10\)"),
    (damaged(set_attr("row", lambda v: v[:-1]), "coo"), r"A \(coo\): row, col and data hold 37, 38 and 38 entries"),
])
def test_damaged_sparse_matrices_are_refused_before_scipy_uses_them(matrix, message):
    with pytest.raises(ValueError, match=message + r".*repair A's"):
        sparsemps.solve(matrix, np.ones(10))


@pytest.mark.parametrize("make, error, message", [
    (lambda: damaged(set_item("data", 4, np.nan)), sparsemps.SolverError, r"NaN or Inf in the matrix"),
    (lambda: np.ones((3, 4)), sparsemps.SolverError, r"matrix and vector sizes do not match \(matrix 3 x 4, b 10"),
    (lambda: np.ones((2, 2, 2)), TypeError, r"A must be a scipy.sparse matrix or convertible to one"),
])
def test_matrices_scipy_accepts_but_the_solver_cannot_take_are_refused(make, error, message):
    with pytest.raises(error, match=message):
        sparsemps.solve(make(), np.ones(10))
