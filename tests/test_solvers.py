"""Solvers of the heat and integration systems: every method against a dense solve,
the pure-scipy fallback when the optional packages are missing, non-convergence."""

import re
import sys
import types
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ndboundary import solvers
from ndboundary.solvers import amg, amg_hierarchy, cholesky, common
from ndboundary.datasets import ball, circle, kuhn_grid, label_by


def _system(n, dim):
    dom = kuhn_grid(n, dim, jitter=0.25, random_state=0)
    lab = label_by(dom, ball if dim == 3 else circle).astype(np.float64)
    # element labels: one constraint row (a single 1) per vertex touching both regions
    inc = sp.csr_matrix(dom.incidence)
    zeta = np.flatnonzero(((inc @ lab) > 0) & ((inc @ (1 - lab)) > 0))
    S = sp.csr_matrix((np.ones(zeta.size), (np.arange(zeta.size), zeta)), shape=(zeta.size, dom.n_vertices))
    h = dom.mean_edge_length()
    K = (dom.K * h ** (2 - dim)).tocsr()
    mass = dom.mass / h**dim
    return K, mass, S


@pytest.fixture(scope="module", params=[(12, 2), (6, 3)], ids=["2d", "3d"])
def system(request):
    K, mass, S = _system(*request.param)
    lam, mu = 2.0, 0.03
    Q = (K @ sp.diags(1 / mass) @ K + mu * K + lam * (S.T @ S)).toarray()
    rng = np.random.default_rng(0)
    rhs = rng.standard_normal(K.shape[0])
    exact = np.linalg.solve(Q, rhs)
    return K, mass, S, lam, mu, rhs, exact


@pytest.fixture(autouse=True)
def _fresh():
    """Each test sees the once-per-process fallback warnings afresh, and leaves them as they were."""
    saved = set(common._warned)
    yield
    common._warned.clear()
    common._warned.update(saved)


class CountingCache(solvers.FactorCache):
    """A FactorCache that counts the factorisations / preconditioners it builds."""

    def __init__(self):
        super().__init__()
        self.builds = 0

    def get(self, kind, A, build):
        def counted(M):
            self.builds += 1
            return build(M)

        return super().get(kind, A, counted)


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


FACTOR_BACKENDS = ["pardiso", "cvxopt", "cholmod", "superlu"]
COMBOS = [
    {"method": "auto"},
    *({"method": "direct", "backend": b} for b in FACTOR_BACKENDS),
    *({"method": "pcg", "preconditioner": "cholesky", "backend": b} for b in FACTOR_BACKENDS),
    {"method": "pcg", "preconditioner": "amg"},
]


def _skip_unless_available(name):
    if name not in solvers.available_backends():
        pytest.skip(f"backend {name!r} not installed")


@pytest.mark.parametrize("kw", COMBOS, ids=lambda kw: "-".join(kw.values()))
def test_integration_matches_dense(system, kw):
    K, mass, S, lam, mu, rhs, exact = system
    _skip_unless_available(kw.get("backend", "superlu"))
    if kw.get("preconditioner") == "amg":
        _skip_unless_available("amg")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, **kw)
    assert _rel(phi, exact) < 1e-8
    assert info.residual < 1e-9
    assert info.method in ("cholesky", "pcg-amg", "pcg-cholesky")


def test_auto_picks_by_row_density(monkeypatch):
    K2, m2, S2 = _system(12, 2)
    K3, m3, S3 = _system(6, 3)
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", 0)
    _, info2 = solvers.solve_integration(K2, m2, S2, 2.0, np.ones(K2.shape[0]), mu=0.03)
    _, info3 = solvers.solve_integration(K3, m3, S3, 2.0, np.ones(K3.shape[0]), mu=0.03)
    assert info2.method == "cholesky"
    expected = "pcg-amg" if "amg" in solvers.available_backends() else "pcg-cholesky"
    assert info3.method == expected
    # up to PCG_FACTOR_MAX unknowns, dense rows are preconditioned by a factor of K + D
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", K3.shape[0])
    phi3, info3 = solvers.solve_integration(K3, m3, S3, 2.0, np.ones(K3.shape[0]), mu=0.03)
    assert info3.method == "pcg-cholesky" and info3.residual < 1e-9


def _knn_graph_operator(n, k, seed=0):
    """``L + I / n`` for the symmetrised ``k``-nearest-neighbour graph of ``n`` random points."""
    from scipy.spatial import cKDTree

    X = np.random.default_rng(seed).standard_normal((n, 5))
    _, idx = cKDTree(X).query(X, k + 1)
    rows = np.repeat(np.arange(n), k)
    W = sp.csr_matrix((np.ones(n * k), (rows, idx[:, 1:].ravel())), shape=(n, n))
    W = ((W + W.T) > 0).astype(np.float64)
    W = W @ W  # two-ring: neighbour graphs of the classifier have ~90 entries per row
    W.setdiag(0)
    W.eliminate_zeros()
    L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    return (L + sp.identity(n) / n).tocsr()


@pytest.mark.parametrize("case", ["mesh", "graph"])
def test_amg_hierarchy_is_csr_and_smoothing_follows_row_density(case, monkeypatch):
    _skip_unless_available("amg")
    import pyamg

    if case == "mesh":
        K, mass, _S = _system(14, 3)
        A = (K + sp.diags(0.1 * mass)).tocsr()
    else:
        A = _knn_graph_operator(4000, 10)
    built = {}
    original = pyamg.smoothed_aggregation_solver

    def spy(*args, **kwargs):
        built["kwargs"] = kwargs
        ml = original(*args, **kwargs)
        built["levels"] = ml.levels
        return ml

    def spy_compiled(*args, **kwargs):
        built["compiled"] = kwargs
        built["levels"] = amg_hierarchy.energy_hierarchy(*args, **kwargs)
        return built["levels"]

    monkeypatch.setattr(pyamg, "smoothed_aggregation_solver", spy)
    monkeypatch.setattr(amg, "energy_hierarchy", spy_compiled)
    apply = amg.amg_preconditioner(A)
    dense = A.nnz / A.shape[0] > solvers.AMG_DENSE_ROWS
    assert dense == (case == "graph")
    # graphs: pyamg's hierarchy with a Jacobi step; meshes: the compiled energy minimisation
    if dense:
        assert built["kwargs"]["smooth"] == "jacobi" and "compiled" not in built
    else:
        assert built["compiled"] == {"maxiter": 2, "max_coarse": 500, "theta": amg.AMG_STRENGTH}
        assert "kwargs" not in built
    levels = built["levels"]
    assert len(levels) >= 2
    for level in levels:
        for name in ("A", "P", "R"):
            if getattr(level, name, None) is not None:
                assert getattr(level, name).format == "csr"
    # a symmetric positive definite operator (to the single precision of its cycle), close
    # enough to A^{-1} to precondition CG
    rng = np.random.default_rng(1)
    u, v = rng.standard_normal((2, A.shape[0]))
    assert np.isclose(u @ apply(v), v @ apply(u), rtol=1e-5)
    assert u @ apply(u) > 0
    b = A @ rng.standard_normal(A.shape[0])
    x = apply(b)
    for _ in range(9):
        x = x + apply(b - A @ x)
    assert np.linalg.norm(b - A @ x) < 1e-3 * np.linalg.norm(b)


def _mesh_operator(n, dim, diagonal, shuffled=False):
    """``K + D`` on a Kuhn grid: ``D`` a tenth of the lumped mass (``"mass"``) or, as on a
    band system, the mass on one vertex in twenty and zero elsewhere (``"sparse"``); the
    columns of each row in random order for ``shuffled``.
    """
    dom = kuhn_grid(n, dim, jitter=0.25, random_state=0)
    rng = np.random.default_rng(0)
    d = 0.1 * dom.mass if diagonal == "mass" else np.where(rng.random(dom.n_vertices) < 0.05, dom.mass, 0.0)
    A = (dom.K + sp.diags(d)).tocsr()
    if shuffled:
        for i in range(A.shape[0]):
            row = slice(A.indptr[i], A.indptr[i + 1])
            order = rng.permutation(A.indptr[i + 1] - A.indptr[i])
            A.indices[row], A.data[row] = A.indices[row][order], A.data[row][order]
        A.has_sorted_indices = False
    return A


@pytest.mark.parametrize(
    "n, dim, diagonal, shuffled",
    [(12, 3, "mass", False), (12, 3, "mass", True), (30, 3, "sparse", False), (60, 2, "sparse", False)],
    ids=["3d", "3d-unsorted", "3d-band-like", "2d-band-like"],
)
def test_compiled_hierarchy_reproduces_pyamg(n, dim, diagonal, shuffled):
    _skip_unless_available("amg")
    import pyamg

    A = _mesh_operator(n, dim, diagonal, shuffled)
    original = A.copy()
    levels = amg_hierarchy.energy_hierarchy(A, maxiter=2, max_coarse=500)
    assert (A != original).nnz == 0 and np.array_equal(A.indices, original.indices)  # A untouched
    ml = pyamg.smoothed_aggregation_solver(
        original, symmetry="symmetric", strength="symmetric", smooth=("energy", {"maxiter": 2}),
        improve_candidates=None, max_coarse=500, keep=True,
    )  # fmt: skip
    assert len(levels) == len(ml.levels) >= 2
    for k, (mine, theirs) in enumerate(zip(levels, ml.levels, strict=True)):
        A_ref = theirs.A.tocsr()
        if k > 0:  # the coarse operators list their columns in pyamg's order
            assert np.array_equal(mine.A.indptr, A_ref.indptr) and np.array_equal(mine.A.indices, A_ref.indices)
        assert spla.norm(mine.A - A_ref) < 1e-12 * spla.norm(A_ref)
        if k == len(levels) - 1:
            assert mine.P is None and mine.aggregates is None
            continue
        AggOp = theirs.AggOp.tocsr()
        aggregates = np.full(AggOp.shape[0], -1)
        aggregates[np.repeat(np.arange(AggOp.shape[0]), np.diff(AggOp.indptr))] = AggOp.indices
        assert np.array_equal(mine.aggregates, aggregates)
        P_ref = theirs.P.tocsr()
        assert np.array_equal(mine.P.indptr, P_ref.indptr) and np.array_equal(mine.P.indices, P_ref.indices)
        assert _rel(mine.P.data, P_ref.data) < 1e-12
        assert (mine.R != mine.P.T).nnz == 0
        if k == 0:  # the coarse candidate vector still interpolates the constants
            assert np.allclose(mine.P @ np.sqrt(np.bincount(mine.aggregates)), 1.0, rtol=0, atol=1e-12)


def test_compiled_v_cycle_is_spd_and_equals_pyamgs():
    _skip_unless_available("amg")
    import pyamg

    A = _mesh_operator(8, 3, "sparse")  # 729 unknowns: two levels
    apply = amg.amg_preconditioner(A)
    n = A.shape[0]
    M = np.column_stack([apply(e) for e in np.eye(n)])
    assert np.abs(M - M.T).max() < 1e-6 * np.abs(M).max()  # symmetric to the cycle's single precision
    # I - M A is the cycle's error propagation: A-symmetric, its spectrum in [0, 1)
    with common.one_blas_thread():
        L = np.linalg.cholesky(A.toarray())
        spectrum = np.linalg.eigvalsh(L.T @ M @ L)
    assert spectrum.min() > 0.1 and spectrum.max() < 1 + 1e-5
    # the cycle over pyamg's own hierarchy, aggregated as pyamg's standard aggregation of
    # the strong couplings aggregates them
    from pyamg.aggregation.aggregate import standard_aggregation

    indptr, indices = amg_hierarchy.strong_pattern(A, amg.AMG_STRENGTH)
    AggOp = standard_aggregation(sp.csr_matrix((np.ones(indices.size), indices, indptr), shape=A.shape))[0]
    ml = pyamg.smoothed_aggregation_solver(
        A, symmetry="symmetric", strength="symmetric", aggregate=("predefined", {"AggOp": sp.csr_matrix(AggOp)}),
        smooth=("energy", {"maxiter": 2}), improve_candidates=None, max_coarse=500,
    )  # fmt: skip
    assert len(ml.levels) >= 2
    for level in ml.levels[:-1]:
        level.P, level.R = level.P.tocsr(), level.R.tocsr()
    for level in ml.levels:
        level.A = level.A.tocsr()
    ref = amg._v_cycle(ml.levels, lambda b: ml.coarse_solver(ml.levels[-1].A, b), 2, pyamg.amg_core.gauss_seidel)
    v = np.random.default_rng(0).standard_normal(n)
    assert _rel(apply(v), ref(v)) < 1e-12


@pytest.mark.parametrize("sweeps", [1, 2, 3])
def test_the_sweeps_that_return_their_residual_are_pyamgs_sweeps_and_a_product(sweeps, monkeypatch):
    """The forward sweeps of the V-cycle's pre-smoothing, which scatter each row's change
    to the residual instead of forming it by a product afterwards, leave pyamg's iterate
    and the true residual in single precision, and the V-cycle built on them is the one
    that sweeps by pyamg and forms its residuals."""
    _skip_unless_available("amg")
    import pyamg

    from ndboundary.solvers.amg_sweeps import ForwardSweeps

    A = _mesh_operator(10, 3, "sparse").astype(np.float32)
    b = np.random.default_rng(1).standard_normal(A.shape[0]).astype(np.float32)
    fused = ForwardSweeps(A)
    x, r = fused.from_zero(b)
    for _ in range(sweeps - 1):
        r = fused.sweep(b, x)
    ref = np.zeros_like(b)
    for _ in range(sweeps):
        pyamg.amg_core.gauss_seidel(A.indptr, A.indices, A.data, ref, b, 0, A.shape[0], 1)
    assert _rel(x, ref) < 1e-5
    assert _rel(r, b - A @ x) < 1e-4 and np.linalg.norm(r) < 0.5 * np.linalg.norm(b)

    A64 = A.astype(np.float64)
    v = b.astype(np.float64)
    made, real = [], amg._forward_sweeps
    monkeypatch.setattr(amg, "_forward_sweeps", lambda A: made.append(real(A)) or made[-1])
    apply = amg.amg_preconditioner(A64, sweeps=sweeps)
    assert len(made) >= 2 and all(m is not None for m in made)  # every level's pre-smoothing fused
    monkeypatch.setattr(amg, "_forward_sweeps", lambda A: None)
    assert _rel(apply(v), amg.amg_preconditioner(A64, sweeps=sweeps)(v)) < 1e-5


def test_the_fused_sweeps_refuse_what_they_cannot_sweep():
    from ndboundary.solvers.amg_sweeps import ForwardSweeps

    A = _mesh_operator(4, 2, "sparse").astype(np.float32)
    with pytest.raises(TypeError, match="float32"):
        ForwardSweeps(A.astype(np.float64))
    unsorted = A.copy()
    unsorted.indices[:2] = unsorted.indices[1::-1]
    unsorted.has_sorted_indices = False
    with pytest.raises(ValueError, match="sorted"):
        ForwardSweeps(unsorted)
    with pytest.raises(ValueError, match="positive diagonal"):
        ForwardSweeps(sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 0.0]], dtype=np.float32)))


def _relax_system(n, r):
    """The integration system ``relax`` builds on a tetrahedral grid labelled by a ball of
    radius ``r``: with the vertices padding adds inside the elements at zeta, light
    against their neighbours (as are those of a band's ragged edge).
    """
    import ndboundary.pipeline.integration as step
    from ndboundary import relax

    grid = kuhn_grid(n, 3, jitter=0.25, random_state=0)
    captured = {}

    class Captured(Exception):
        pass

    def capture(K, mass, S, lam, rhs, *, mu=0.0, **_kw):
        captured.update(K=sp.csr_matrix(K), mass=mass, S=sp.csr_matrix(S), lam=lam, mu=mu)
        raise Captured

    real = step.solve_integration
    step.solve_integration = capture
    try:
        relax(grid, label_by(grid, lambda x: ball(x, r=r)), on="elements")
    except Captured:
        pass
    finally:
        step.solve_integration = real
    return captured


def test_blas_limits_entered_on_two_threads_are_restored_when_both_close():
    """Contexts opened and closed on two threads in turn (the relaxation's solve beside its
    preconditioner's build) keep the limit while any is open and leave the limits they
    found."""
    import threading

    threadpoolctl = pytest.importorskip("threadpoolctl")

    def blas_limits():
        return sorted(p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas")

    before = blas_limits()
    if not before:
        pytest.skip("no BLAS thread pool found")
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()

    def first():
        with common.blas_threads(1):
            first_in.set()
            second_in.wait()
        first_out.set()

    thread = threading.Thread(target=first)
    thread.start()
    first_in.wait()
    with common.blas_threads(1):
        second_in.set()
        first_out.wait()  # the first closed while this one is open: the limit holds
        assert blas_limits() == [1] * len(before)
    thread.join()
    assert blas_limits() == before


@pytest.mark.parametrize("first_alone", [True, False])
def test_blocks_on_threads_cover_the_rows_in_order_with_one_blas_thread_each(monkeypatch, first_alone):
    """Every thread gets a block, no block is cut below MIN_BLOCK rows, BLAS runs one
    thread per block meanwhile, and its limits are back when the blocks are done."""
    from ndboundary import _threads

    threadpoolctl = pytest.importorskip("threadpoolctl")

    def blas_limits():
        # the builds on POSIX threads: an OpenMP build (MKL's too) keeps a thread count per
        # calling thread, so a limit set here does not reach the blocks' threads
        return sorted(
            (p["filepath"], p["num_threads"])
            for p in threadpoolctl.threadpool_info()
            if p["user_api"] == "blas" and p.get("threading_layer") == "pthreads"
        )

    before = blas_limits()
    monkeypatch.setattr(_threads, "available_threads", lambda: 2)
    seen = []

    def compute(c):
        seen.append(blas_limits())
        return c.stop - c.start

    blocks = list(_threads.in_blocks(1000, 4096, compute, first_alone=first_alone))
    sizes = [size for _, size in blocks]
    assert [c.start for c, _ in blocks] == list(np.cumsum([0] + sizes[:-1]))
    assert sum(sizes) == 1000 and len(blocks) == (3 if first_alone else 2)
    assert all([t for _, t in limits] == [1] * len(before) for limits in seen), (before, seen)
    assert blas_limits() == before
    few = list(_threads.in_blocks(300, 4096, compute, first_alone=first_alone))
    assert [size for _, size in few] == [256, 44]  # not cut below MIN_BLOCK rows


def test_blocks_on_one_thread_are_computed_in_order_on_the_calling_thread(monkeypatch):
    """With one thread available (a Dask worker's ``OMP_NUM_THREADS=1``) no pool is
    started: every block is computed on the caller's thread, in order."""
    import threading

    from ndboundary import _threads

    monkeypatch.setattr(_threads, "available_threads", lambda: 1)
    seen = []

    def compute(c):
        seen.append(threading.get_ident())
        return c.start

    for first_alone in (True, False):
        seen.clear()
        starts = [s for _, s in _threads.in_blocks(1000, 128, compute, first_alone=first_alone)]
        assert starts == list(range(0, 1000, 128))
        assert set(seen) == {threading.get_ident()}


def test_a_relaxation_leaves_the_blas_threads_as_it_found_them():
    """The relaxation builds its integration's preconditioner on a second thread while
    the heat is solved, each limiting BLAS: the limits are lifted on the thread that set
    the first, so that every library runs as many threads after as before."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from ndboundary import relax
    from ndboundary.datasets import circle, label_by, voronoi_polygons

    def blas_threads_by_library():
        return {p["filepath"]: p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"}

    mesh = voronoi_polygons(80, random_state=0)
    labels = label_by(mesh, circle)
    relax(mesh, labels, on="elements", band=None)  # what the relaxation loads, loaded
    before = blas_threads_by_library()
    if not before:
        pytest.skip("no BLAS thread pool found")
    for _ in range(3):
        relax(mesh, labels, on="elements", band=None)
        assert blas_threads_by_library() == before


def test_a_fit_that_fails_leaves_no_work_beside_it_running(monkeypatch):
    """The kernel fit's features run beside the relaxation; when the relaxation raises,
    the fit waits for them before it raises, so that nothing of it goes on after."""
    import threading
    import time

    from sklearn.datasets import make_classification

    from ndboundary import LevelSetClassifier, _threads
    from ndboundary.learn import classifier

    monkeypatch.setattr(_threads, "available_threads", lambda: 2)
    done = threading.Event()

    def slow_basis(*args):
        time.sleep(0.3)
        done.set()

    def failing_relax(*args, **kwargs):
        raise FloatingPointError("the relaxation failed")

    monkeypatch.setattr(classifier, "kernel_basis", slow_basis)
    monkeypatch.setattr(classifier, "relax_classes", failing_relax)
    X, y = make_classification(300, 5, random_state=0)
    with pytest.raises(FloatingPointError, match="relaxation failed"):
        LevelSetClassifier().fit(X, y)
    assert done.is_set()


def test_a_classifier_fit_leaves_the_blas_threads_as_it_found_them():
    """The fit limits BLAS on its own thread and beside it (the kernel fit's features) and
    loads libraries on the way: every library runs as many threads after it as before."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from sklearn.datasets import make_classification

    from ndboundary import LevelSetClassifier

    def blas_threads_by_library():
        return {p["filepath"]: p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"}

    X, y = make_classification(1500, 8, random_state=0)
    LevelSetClassifier().fit(X[:300], y[:300])  # what the fit loads, loaded
    before = blas_threads_by_library()
    if not before:
        pytest.skip("no BLAS thread pool found")
    for _ in range(3):
        LevelSetClassifier().fit(X, y)
        assert blas_threads_by_library() == before


def test_blocks_within_blocks_are_computed_and_an_early_stop_leaves_no_block_running(monkeypatch):
    """A block that splits its own rows into blocks gets them computed, while its
    siblings hold the other threads; a caller that stops reading finds every block it
    started finished."""
    import threading

    from ndboundary import _threads

    monkeypatch.setattr(_threads, "available_threads", lambda: 2)

    def inner(c):
        return sum(size for _, size in _threads.in_blocks(c.stop - c.start, 4, lambda d: d.stop - d.start))

    totals = [total for _, total in _threads.in_blocks(2000, 300, inner, first_alone=False)]
    assert sum(totals) == 2000 and len(totals) == 7
    running, done = threading.Event(), []

    def slow(c):
        running.set()
        threading.Event().wait(0.05)
        done.append(c.start)
        return c.start

    blocks = _threads.in_blocks(3000, 300, slow, first_alone=False)
    next(blocks)
    blocks.close()  # the blocks submitted ahead are cancelled, or waited for
    count = len(done)
    threading.Event().wait(0.2)
    assert len(done) == count


def test_a_preconditioner_built_ahead_solves_as_the_one_built_in_the_solve():
    _skip_unless_available("amg")
    from ndboundary.solvers.integration import Preconditioner, integration_preconditioner

    captured = _relax_system(12, 0.3)
    K, mass, S, lam, mu = (captured[k] for k in ("K", "mass", "S", "lam", "mu"))
    rhs = np.random.default_rng(1).standard_normal(K.shape[0])
    exact = np.linalg.solve((K @ sp.diags(1 / mass) @ K + mu * K + lam * (S.T @ S)).toarray(), rhs)
    for sweeps in (1, 2):
        kw = {"mu": mu, "method": "pcg", "preconditioner": "amg", "sweeps": sweeps}
        pre = integration_preconditioner(K, mass, S, lam, **kw)
        assert isinstance(pre, Preconditioner) and pre.method == "pcg-amg" and pre.setup_time > 0
        ahead, info = solvers.solve_integration(K, mass, S, lam, rhs, rtol=1e-8, **{**kw, "preconditioner": pre})
        inside, info2 = solvers.solve_integration(K, mass, S, lam, rhs, rtol=1e-8, **kw)
        assert np.array_equal(ahead, inside) and info.iterations == info2.iterations
        assert info.setup_time >= pre.setup_time
        assert _rel(ahead, exact) < 1e-6
    # one sweep each way keeps the V-cycle symmetric positive definite
    A = _mesh_operator(8, 3, "sparse")
    M = np.column_stack([amg.amg_preconditioner(A, sweeps=1)(e) for e in np.eye(A.shape[0])])
    assert np.abs(M - M.T).max() < 1e-6 * np.abs(M).max() and np.linalg.eigvalsh(M).min() > 0
    with pytest.raises(ValueError, match="Preconditioner"):
        integration_preconditioner(K, mass, S, lam, preconditioner="jacobi")
    K2, mass2, S2 = _system(12, 2)
    # an iteration preconditioned by a factor of K + D factorises in the solve
    assert integration_preconditioner(K2, mass2, S2, 1.0, preconditioner="cholesky", method="pcg") is None
    # a system the solve factorises gets its factor ahead, which solves as the solve's own
    rhs2 = np.random.default_rng(2).standard_normal(K2.shape[0])
    factor = integration_preconditioner(K2, mass2, S2, 1.0, mu=0.1)
    if not cholesky.fast_cholesky_available():  # the solve factorises, and warns of the cost
        assert factor is None
        return
    assert isinstance(factor, solvers.integration.IntegrationFactor) and factor.setup_time > 0
    ahead, info = solvers.solve_integration(K2, mass2, S2, 1.0, rhs2, mu=0.1, preconditioner=factor)
    inside, info2 = solvers.solve_integration(K2, mass2, S2, 1.0, rhs2, mu=0.1)
    assert info.method == info2.method == "cholesky" and info.setup_time == factor.setup_time
    np.testing.assert_allclose(ahead, inside, rtol=1e-12, atol=1e-12)
    assert info.residual < 1e-10


@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_the_upper_triangle_compiled_is_the_sparse_products(index):
    from ndboundary._compiled import squared_upper

    K, mass, _ = _system(10, 2)
    rng = np.random.default_rng(0)
    # rows of two weights, as the midpoints of cut edges pin a vertex labelling: S^T S couples them
    cols = rng.choice(K.shape[0], (30, 2), replace=False)
    S = sp.csr_matrix((np.full(60, 0.5), (np.repeat(np.arange(30), 2), cols.ravel())), shape=(30, K.shape[0]))
    T = (S.T @ S).tocsr()
    K = sp.csr_matrix((K.data, K.indices.astype(index), K.indptr.astype(index)), shape=K.shape)
    U = squared_upper(K, mass, 0.1, T, 3.0)
    Q = (K @ sp.diags(1 / mass) @ K + 0.1 * K + 3.0 * T).toarray()
    np.testing.assert_allclose(U.toarray(), np.triu(Q), rtol=1e-13, atol=1e-13 * np.abs(Q).max())
    assert all((np.diff(U.indices[a:b]) > 0).all() for a, b in zip(U.indptr[:-1], U.indptr[1:], strict=True))


def test_a_factor_built_beside_other_work_holds_no_gil_and_solves_as_the_solves_own():
    """Beside the field's steps the factor is PARDISO's, of the upper triangle the
    compiled assembly gives: the same solution as the solve's own factor."""
    _skip_unless_available("pardiso")
    from ndboundary.solvers.integration import IntegrationFactor, integration_preconditioner

    K, mass, S = _system(12, 2)
    rhs = np.random.default_rng(2).standard_normal(K.shape[0])
    factor = integration_preconditioner(K, mass, S, 1.0, mu=0.1, concurrent=True)
    assert isinstance(factor, IntegrationFactor) and not sp.issparse(factor.Q)
    x = np.random.default_rng(3).standard_normal(K.shape[0])
    Q = (K @ sp.diags(1 / mass) @ K + 0.1 * K + S.T @ S).tocsr()
    np.testing.assert_allclose(factor.Q @ x, Q @ x, rtol=1e-12, atol=1e-12 * np.abs(Q @ x).max())
    ahead, info = solvers.solve_integration(K, mass, S, 1.0, rhs, mu=0.1, preconditioner=factor)
    inside, _ = solvers.solve_integration(K, mass, S, 1.0, rhs, mu=0.1)
    np.testing.assert_allclose(ahead, inside, rtol=1e-9, atol=1e-9 * np.abs(inside).max())
    assert info.method == "cholesky" and info.residual < 1e-10


def test_pardiso_is_found_without_importing_pypardiso():
    """pypardiso's import and its search of the environment took over a second; PARDISO's
    availability and its first factorisation need neither."""
    import subprocess

    code = (
        "import sys, numpy as np, scipy.sparse as sp\n"
        "from ndboundary.solvers import pardiso\n"
        "ok = pardiso.available()\n"
        "x = pardiso.PardisoFactor(sp.diags([2.0, 4.0]).tocsr()).solve(np.ones(2)) if ok else None\n"
        "print(ok, 'pypardiso' in sys.modules, None if x is None else x.tolist())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split(" ", 2)
    if out[0] == "False":
        pytest.skip("PARDISO is not installed")
    assert out[1] == "False" and np.allclose(eval(out[2]), [0.5, 0.25], rtol=1e-14)


def test_light_vertices_get_a_jacobi_step_around_the_v_cycle(monkeypatch):
    _skip_unless_available("amg")
    captured = _relax_system(12, 0.3)
    K, mass, S, lam, mu = (captured[k] for k in ("K", "mass", "S", "lam", "mu"))
    A = (K + sp.diags(0.5 * mu * mass)).tocsr()
    apply = amg.amg_preconditioner(A)
    wrapped = amg.light_vertex_jacobi(A, mass, apply)
    assert wrapped is not apply
    # symmetric positive definite, and no residual left on a light vertex without light neighbours
    rng = np.random.default_rng(0)
    u, v = rng.standard_normal((2, K.shape[0]))
    assert np.isclose(u @ wrapped(v), v @ wrapped(u), rtol=1e-5) and u @ wrapped(u) > 0
    ones = sp.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    degree = np.diff(A.indptr) - 1
    light = mass < solvers.LIGHT_VERTEX_SHARE * (ones @ mass - mass) / degree
    alone = light & (ones @ light.astype(np.float64) == 1)
    assert alone.sum() > 10
    r = np.abs(v - A @ wrapped(v))
    assert r[alone].max() < 1e-12 * r.max()
    # on a uniform mass nothing is light: the V-cycle alone
    assert amg.light_vertex_jacobi(A, np.ones_like(mass), apply) is apply
    # the integration: the solution within rtol, in fewer iterations than the V-cycle alone
    rhs = rng.standard_normal(K.shape[0])
    Q = (K @ sp.diags(1 / mass) @ K + mu * K + lam * (S.T @ S)).toarray()
    exact = np.linalg.solve(Q, rhs)
    kw = {"mu": mu, "method": "pcg", "preconditioner": "amg", "maxiter": 1000}
    phi, info = solvers.solve_integration(K, mass, S, lam, rhs, **kw)
    assert info.residual <= 1e-10 and _rel(phi, exact) < 1e-7
    monkeypatch.setattr(solvers, "LIGHT_VERTEX_SHARE", 0.0)
    plain, info0 = solvers.solve_integration(K, mass, S, lam, rhs, **kw)
    assert info0.residual <= 1e-10 and _rel(plain, exact) < 1e-7
    assert info.iterations < 0.8 * info0.iterations, (info.iterations, info0.iterations)


def test_fallback_without_optional_packages(system, monkeypatch):
    K, mass, S, lam, mu, rhs, exact = system
    # the packages "missing": importing them raises ImportError
    for mod in ("pypardiso", "cvxopt", "cvxopt.cholmod", "sksparse_minimal", "pyamg"):
        monkeypatch.setitem(sys.modules, mod, None)
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", 0)
    common._warned.clear()
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        phi, _info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu)
        phi2, _ = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu)
    rec = [w for w in rec if issubclass(w.category, solvers.SolverFallbackWarning)]
    assert len(rec) == 1  # one line, once per process
    message = str(rec[0].message)
    assert "\n" not in message and "slower" in message
    if K.nnz / K.shape[0] > solvers.DENSE_ROW_THRESHOLD:  # 3-D: pyamg's absence costs time
        assert "pyamg" in message
    else:  # triangles: SuperLU factorises instead of PARDISO / cvxopt
        assert "pypardiso" in message and "cvxopt" in message
    assert _rel(phi, exact) < 1e-8 and _rel(phi2, exact) < 1e-8
    assert solvers.available_backends() == ["superlu"]
    with pytest.raises(ImportError):
        solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="pcg", preconditioner="amg")
    for backend in ("pardiso", "cvxopt", "cholmod"):
        with pytest.raises(ImportError, match="needs the package"):
            solvers.factorize_spd(sp.identity(3, format="csc"), backend=backend)


def test_small_systems_do_not_warn_without_fast_packages(monkeypatch):
    K, mass, S = _system(12, 2)  # 169 unknowns, below SMALL_SYSTEM
    for mod in ("pypardiso", "cvxopt", "cvxopt.cholmod", "sksparse_minimal"):
        monkeypatch.setitem(sys.modules, mod, None)
    common._warned.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error", solvers.SolverFallbackWarning)
        solvers.solve_integration(K, mass, S, 2.0, np.ones(K.shape[0]), mu=0.03)


def test_nonconvergence_warns_with_residual(system):
    K, mass, S, lam, mu, rhs, _exact = system
    with pytest.warns(RuntimeWarning, match=r"did not converge in 2 iterations \(relative residual"):
        _phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="pcg", maxiter=2)
    assert info.iterations == 2 and info.residual > 1e-9


def test_auto_falls_back_to_direct_when_pcg_stalls(system, monkeypatch):
    K, mass, S, lam, mu, rhs, exact = system
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", 0)
    monkeypatch.setattr(solvers, "DENSE_ROW_THRESHOLD", 0.0)  # force the pcg path
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, maxiter=2)
    assert info.method == "cholesky" and info.iterations == 2
    assert _rel(phi, exact) < 1e-8


def test_cache_reuses_and_is_correct(system):
    K, mass, S, lam, mu, rhs, exact = system
    cache = CountingCache()
    _phi1, _ = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="direct", cache=cache)
    assert len(cache) == 1 and cache.builds == 1
    phi2, _info = solvers.solve_integration(K, mass, S, lam, 2 * rhs, mu=mu, method="direct", cache=cache)
    assert _rel(phi2, 2 * exact) < 1e-8
    assert cache.builds == 1  # the same matrix: its factor is reused
    # a different matrix must not hit the cache
    phi3, _ = solvers.solve_integration(K, mass, S, 2 * lam, rhs, mu=mu, method="direct", cache=cache)
    Q3 = (K @ sp.diags(1 / mass) @ K + mu * K + 2 * lam * (S.T @ S)).toarray()
    assert _rel(phi3, np.linalg.solve(Q3, rhs)) < 1e-8
    assert cache.builds == 2 and len(cache) == 1  # one entry: the new factor replaced the old
    cache.clear()
    assert len(cache) == 0 and cache.nbytes == 0 and not cache.orderings


def test_no_cache_keeps_nothing(system):
    K, mass, S, lam, mu, rhs, exact = system
    for _ in range(2):  # cache=None, the default: every solve factorises afresh, and is right
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="direct")
        assert info.method == "cholesky" and _rel(phi, exact) < 1e-8


def test_heat_matches_dense(system):
    K, mass, *_ = system
    b = np.random.default_rng(1).random(K.shape[0])
    u, info = solvers.solve_heat(mass, K, 1.0, b)
    A = (sp.diags(mass) + K).toarray()
    assert _rel(u, np.linalg.solve(A, b)) < 1e-8
    assert info.method == "cg-jacobi"


def _spd(n=60, seed=0):
    A = sp.random(n, n, density=0.1, random_state=seed)
    return (A @ A.T + n * sp.identity(n)).tocsr()


@pytest.mark.parametrize("backend", FACTOR_BACKENDS)
def test_factorize_spd_backends_match_superlu(backend):
    _skip_unless_available(backend)
    A = _spd()
    rng = np.random.default_rng(0)
    b = rng.standard_normal(A.shape[0])
    B = rng.standard_normal((A.shape[0], 3))
    ref = solvers.factorize_spd(A, backend="superlu")
    solve = solvers.factorize_spd(A, backend=backend)
    x = solve(b)
    assert x.shape == b.shape and _rel(x, ref(b)) < 1e-12
    assert _rel(x, np.linalg.solve(A.toarray(), b)) < 1e-12
    X = solve(B)  # several right-hand sides at once
    assert X.shape == B.shape and _rel(X, np.linalg.solve(A.toarray(), B)) < 1e-12
    assert _rel(solve(b), x) == 0.0  # the factor is reused, not consumed
    # CSC input, as from scipy's sparse products
    assert _rel(solvers.factorize_spd(A.tocsc(), backend=backend)(b), x) < 1e-12


def test_factorize_spd_rejects_unknown_backend():
    with pytest.raises(ValueError, match="backend must be one of"):
        solvers.factorize_spd(_spd(), backend="nope")


BACKEND_MODULES = ("cvxopt", "cvxopt.cholmod", "pypardiso", "sksparse_minimal")


def _fake_installed(monkeypatch):
    """Make every optional backend's package importable (an empty module where it is missing)."""
    for mod in BACKEND_MODULES:
        if common.load_optional(mod) is None:
            monkeypatch.setitem(sys.modules, mod, types.ModuleType(mod))


def test_available_backends_follow_the_auto_order():
    names = [b for b in solvers.available_backends() if b != "amg"]
    assert names == [b for b in solvers.BACKENDS if b in names]
    assert names[-1] == "superlu"  # scipy's, always there and always the last resort


@pytest.mark.parametrize("large", [False, True], ids=["small", "large"])
def test_auto_tries_the_backends_in_the_measured_order(monkeypatch, large):
    A = _spd()
    b = np.arange(A.shape[0], dtype=np.float64)
    if large:
        monkeypatch.setattr(solvers, "LARGE_SYSTEM", A.shape[0])
    calls = []

    def broken(name):
        def factor(M, **kwargs):
            calls.append(name)
            raise RuntimeError(f"{name} failed")

        return factor

    # every optional backend "installed" and failing: auto tries each once, in the
    # documented order, then SuperLU, the last resort, solves
    _fake_installed(monkeypatch)
    for name in ("pardiso", "cvxopt", "cholmod"):
        monkeypatch.setitem(cholesky.FACTORISERS, name, broken(name))
    x = solvers.factorize_spd(A)(b)
    assert _rel(x, np.linalg.solve(A.toarray(), b)) < 1e-10
    order = cholesky.auto_order(A.shape[0])
    assert sorted(order) == sorted(solvers.BACKENDS) and order[-1] == "superlu"
    assert calls == order[:-1]
    if large:  # from LARGE_SYSTEM unknowns PARDISO first
        assert calls[0] == "pardiso"
    else:  # below, cvxopt before PARDISO
        assert calls.index("cvxopt") < calls.index("pardiso")
    # a backend named explicitly raises its own error
    with pytest.raises(RuntimeError, match="pardiso failed"):
        solvers.factorize_spd(A, backend="pardiso")


@pytest.mark.parametrize("large", [False, True], ids=["small", "large"])
def test_auto_uses_the_first_available_backend(monkeypatch, large):
    A = _spd()
    if large:
        monkeypatch.setattr(solvers, "LARGE_SYSTEM", A.shape[0])
    calls = []
    real_superlu = cholesky.FACTORISERS["superlu"]

    def recorder(name):
        def factor(M, **kwargs):
            calls.append(name)
            return real_superlu(M)

        return factor

    for name in solvers.BACKENDS:
        monkeypatch.setitem(cholesky.FACTORISERS, name, recorder(name))
    solvers.factorize_spd(A)
    available = solvers.available_backends()
    expected = [b for b in cholesky.auto_order(A.shape[0]) if b in available]
    assert calls == expected[:1]


@pytest.mark.parametrize("backend", ["pardiso", "cvxopt"])
def test_backend_rejects_indefinite_matrix_and_auto_recovers(backend):
    _skip_unless_available(backend)
    A = _spd()
    N = (A - 2 * A.shape[0] * sp.identity(A.shape[0])).tocsr()  # negative definite
    with pytest.raises(Exception):  # noqa: B017 - each package raises its own type
        solvers.factorize_spd(N, backend=backend)
    # auto still returns a solver (SuperLU's LU does not need positive pivots)
    b = np.ones(A.shape[0])
    x = solvers.factorize_spd(N)(b)
    assert _rel(N @ x, b) < 1e-10


def test_importing_ndboundary_does_not_load_optional_backends_nor_scikit_learn():
    """Nor does the command line: scikit-learn loads with the classifier, on first use."""
    import subprocess

    code = (
        "import sys, ndboundary, ndboundary.solvers, ndboundary.cli; "
        "print(sorted(m for m in ('pypardiso', 'cvxopt', 'sksparse_minimal', 'pyamg', 'sklearn') "
        "if m in sys.modules)); "
        "from ndboundary import LevelSetClassifier; "
        "print('sklearn' in sys.modules, ndboundary.learn.LevelSetClassifier is LevelSetClassifier)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[:2] == ["[]", "True True"]


def test_pardiso_releases_its_memory():
    _skip_unless_available("pardiso")
    import gc

    solve = solvers.factorize_spd(_spd(), backend="pardiso")
    factor = solve.__self__
    assert factor.factor_nnz > 0
    finalizer = factor._finalizer
    del solve, factor
    gc.collect()
    assert not finalizer.alive


def test_pardiso_reuses_the_ordering_of_the_same_pattern():
    _skip_unless_available("pardiso")
    A = _spd()
    b = np.arange(A.shape[0], dtype=np.float64)
    cache = solvers.FactorCache()
    first = solvers.factorize_spd(A, backend="pardiso", orderings=cache.orderings)
    assert not first.__self__.reused_ordering
    B = (A + sp.diags(np.linspace(1.0, 2.0, A.shape[0]))).tocsr()  # same pattern
    second = solvers.factorize_spd(B, backend="pardiso", orderings=cache.orderings)
    assert second.__self__.reused_ordering
    assert _rel(second(b), np.linalg.solve(B.toarray(), b)) < 1e-12
    assert _rel(first(b), np.linalg.solve(A.toarray(), b)) < 1e-12  # independent factors
    C = _spd(seed=1)  # another pattern: a new ordering
    assert not solvers.factorize_spd(C, backend="pardiso", orderings=cache.orderings).__self__.reused_ordering
    cache.clear()
    assert not solvers.factorize_spd(A, backend="pardiso", orderings=cache.orderings).__self__.reused_ordering
    # without a place to keep it, nothing is reused
    assert not solvers.factorize_spd(B, backend="pardiso").__self__.reused_ordering


def test_auto_iterates_on_instead_of_factorising_a_large_3d_system(system, monkeypatch):
    K, mass, S, lam, mu, rhs, exact = system
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", 0)
    monkeypatch.setattr(solvers, "DENSE_ROW_THRESHOLD", 0.0)  # force the pcg path
    monkeypatch.setattr(solvers, "DIRECT_FALLBACK_MAX", 0)  # "too large to factorise"
    # a few iterations more than the first round allows are enough here: no factorisation
    # (which would report method "cholesky"), the iteration goes on to rtol
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, maxiter=10)
    assert info.method.startswith("pcg") and info.iterations > 10
    assert info.residual <= 1e-9 and _rel(phi, exact) < 1e-5
    # a tolerance no number of iterations reaches: a warning with the iterations run and
    # the residual reached, still no factorisation
    with pytest.warns(RuntimeWarning, match="too many to factorise") as rec:
        _phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, rtol=1e-20, maxiter=1)
    assert info.method.startswith("pcg") and info.iterations > 1 and info.residual > 1e-19
    message = str(rec[0].message)
    found = re.search(r"did not converge in (\d+) iterations \(relative residual (\S+), target 1e-20\)", message)
    assert found is not None, message
    assert int(found[1]) == info.iterations and found[2] == f"{info.residual:.2e}"


def test_large_direct_solves_refine_a_single_precision_factor(monkeypatch):
    _skip_unless_available("pardiso")
    K, mass, S = _system(12, 2)
    lam, mu = 2.0, 0.03
    Q = (K @ sp.diags(1 / mass) @ K + mu * K + lam * (S.T @ S)).toarray()
    rhs = np.random.default_rng(1).standard_normal(K.shape[0])
    exact = np.linalg.solve(Q, rhs)
    monkeypatch.setattr(solvers, "SINGLE_PRECISION_MIN", 0)
    cache = CountingCache()
    phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, rtol=1e-10, cache=cache)
    assert info.method == "cholesky-single+cg"
    assert 1 <= info.iterations <= solvers.SINGLE_REFINE_MAXITER
    assert info.residual <= 1e-9 and _rel(phi, exact) < 1e-7
    # the same system again reuses the single-precision factor
    again, info2 = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, rtol=1e-10, cache=cache)
    assert info2.method == "cholesky-single+cg" and np.allclose(again, phi, rtol=0, atol=1e-12)
    assert cache.builds == 1
    # another backend, or a refinement that cannot converge, factorises in double precision
    other = "cvxopt" if "cvxopt" in solvers.available_backends() else "superlu"
    _, info3 = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, backend=other)
    assert info3.method == "cholesky"
    monkeypatch.setattr(solvers, "SINGLE_REFINE_MAXITER", 0)
    phi4, info4 = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, rtol=1e-10)
    assert info4.method == "cholesky" and _rel(phi4, exact) < 1e-8


def test_tuning_constants_set_on_the_package_reach_the_solvers(monkeypatch):
    for name in ("DENSE_ROW_THRESHOLD", "SMALL_SYSTEM", "FACTOR_THREADS", "LARGE_SYSTEM",
                 "SINGLE_PRECISION_MIN", "SINGLE_REFINE_MAXITER", "DIRECT_FALLBACK_MAX",
                 "AMG_DENSE_ROWS", "LIGHT_VERTEX_SHARE", "BACKENDS"):  # fmt: skip
        assert hasattr(solvers, name), name
    monkeypatch.setattr(solvers, "FACTOR_THREADS", 2)
    assert solvers.FACTOR_THREADS == 2 and common.FACTOR_THREADS == 2
    # the factorisation reads it at call time
    seen = []
    real = cholesky.blas_threads

    def spy(n):
        seen.append(n)
        return real(n)

    monkeypatch.setattr(cholesky, "blas_threads", spy)
    _skip_unless_available("cvxopt")
    solvers.factorize_spd(_spd(), backend="cvxopt")
    assert seen == [2]


def test_auto_factorises_nearly_dense_matrices_by_lapack(monkeypatch):
    """A matrix of a few thousand unknowns with most entries nonzero (the squared operator
    of a neighbour graph) is factorised dense: no sparse backend is asked, and the solution
    is the dense solve's; one that is not positive definite goes to the sparse backends."""
    n = cholesky.DENSE_MIN
    rng = np.random.default_rng(0)
    B = rng.standard_normal((n, n // 4))
    A = sp.csr_matrix(B @ B.T + n * np.eye(n))
    b = rng.standard_normal(n)
    calls = []

    def broken(M, **kwargs):
        calls.append(M.shape)
        raise RuntimeError("a sparse backend was asked")

    for name in ("pardiso", "cvxopt", "cholmod"):
        monkeypatch.setitem(cholesky.FACTORISERS, name, broken)
    x = solvers.factorize_spd(A)(b)
    assert calls == [] and _rel(x, np.linalg.solve(A.toarray(), b)) < 1e-12
    indefinite = sp.csr_matrix(B @ B.T - np.eye(n))
    solvers.factorize_spd(indefinite)
    installed = sum(common.load_optional(cholesky.BACKENDS[k]) is not None for k in ("pardiso", "cvxopt", "cholmod"))
    assert len(calls) == installed


def test_factor_cache_keeps_the_squared_operator_for_every_labelling():
    """The squared operator is built once per stiffness, mass and mu (compared by content),
    kept when factors are not, and freed by clear()."""
    cache = solvers.FactorCache(keep_factor=False)
    K = sp.csr_matrix([[1.0, -1.0], [-1.0, 1.0]])
    built = []

    def build():
        built.append(1)
        return K @ K

    first = cache.squared(K, [1.0, 1.0], 0.1, build)
    assert cache.squared(K.copy(), np.ones(2), 0.1, build) is first and len(built) == 1
    cache.squared(K, [1.0, 2.0], 0.1, build)  # another mass
    cache.squared(K, [1.0, 2.0], 0.2, build)  # another mu
    assert len(built) == 3
    assert cache.get("x", K, lambda A: object()) is not cache.get("x", K, lambda A: object())  # no factor kept
    cache.clear()
    cache.squared(K, [1.0, 2.0], 0.2, build)
    assert len(built) == 4


def test_neighbour_graphs_are_preconditioned_by_a_factor_up_to_their_own_size(monkeypatch):
    """Rows of K denser than AMG_DENSE_ROWS (a neighbour graph) keep the factor of K + D up
    to PCG_FACTOR_MAX_GRAPHS unknowns, where a mesh's dense rows switch to AMG at PCG_FACTOR_MAX."""
    _skip_unless_available("amg")
    K = _knn_graph_operator(400, 12)
    assert K.nnz / K.shape[0] > solvers.AMG_DENSE_ROWS
    n = K.shape[0]
    S = sp.csr_matrix((np.ones(20), (np.arange(20), np.arange(0, 400, 20))), shape=(20, n))
    rhs = np.random.default_rng(0).standard_normal(n)
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX", 0)
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX_GRAPHS", n)
    phi, info = solvers.solve_integration(K, np.ones(n), S, 2.0, rhs, mu=0.03)
    assert info.method == "pcg-cholesky" and info.residual < 1e-9
    monkeypatch.setattr(solvers, "PCG_FACTOR_MAX_GRAPHS", n - 1)
    phi2, info2 = solvers.solve_integration(K, np.ones(n), S, 2.0, rhs, mu=0.03)
    assert info2.method == "pcg-amg" and _rel(phi2, phi) < 1e-7


@pytest.mark.parametrize("method", ["auto", "direct", "pcg"])
def test_gradient_integration_matches_dense(system, method):
    K, mass, S, lam, mu, rhs, exact = system
    A = (K + lam * (S.T @ S)).toarray()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        phi, info = solvers.solve_gradient_integration(K, S, lam, rhs, method=method)
    assert _rel(phi, np.linalg.solve(A, rhs)) < 1e-8
    assert info.residual < 1e-9
    # 2-D triangles have sparse rows: auto factorises; pcg on a mesh runs a V-cycle (pyamg installed)
    expected = {"direct": "cholesky", "pcg": "pcg-amg" if "amg" in solvers.available_backends() else "pcg-jacobi"}
    assert info.method == expected.get(method, info.method)


def test_gradient_integration_of_a_linear_function_is_exact_on_a_neighbour_graph():
    """K phi = div(G f) with f itself at the pinned points: phi = f, by Jacobi-preconditioned
    conjugate gradients (the rows of a neighbour graph's stiffness are dense)."""
    from ndboundary import PointCloud

    rng = np.random.default_rng(3)
    cloud = PointCloud(rng.uniform(-1, 1, size=(1500, 3)), n_neighbors=20)
    f = cloud.points @ np.array([0.3, -1.2, 0.7]) + 0.4
    pins = rng.choice(cloud.n_vertices, 40, replace=False)
    S = sp.csr_matrix((np.ones(pins.size), (np.arange(pins.size), pins)), shape=(pins.size, cloud.n_vertices))
    lam = 2.0
    rhs = cloud.div(cloud.G @ f) + lam * (S.T @ f[pins])
    phi, info = solvers.solve_gradient_integration(cloud.K, S, lam, rhs, rtol=1e-12)
    assert info.method == "pcg-jacobi"
    np.testing.assert_allclose(phi, f, atol=1e-8)


def test_gradient_integration_rejects_an_unknown_method(system):
    K, mass, S, lam, mu, rhs, exact = system
    with pytest.raises(ValueError, match="method must be"):
        solvers.solve_gradient_integration(K, S, lam, rhs, method="lu")


def test_strong_pattern_matches_its_definition(rng):
    n = 60
    A = sp.random(n, n, density=0.15, random_state=0, format="csr")
    A = (A + A.T + sp.diags(rng.uniform(1.0, 2.0, n))).tocsr()
    A.data *= rng.choice([-1.0, 1.0], A.data.size)  # signs do not matter, magnitudes do
    indptr, indices = amg_hierarchy.strong_pattern(A, 0.3)
    dense = A.toarray()
    largest = np.abs(dense - np.diag(np.diag(dense))).max(axis=1)
    want = (np.abs(dense) >= 0.3 * np.minimum.outer(largest, largest)) & (A.toarray() != 0)
    np.fill_diagonal(want, np.diag(dense) != 0)
    got = sp.csr_matrix((np.ones(indices.size), indices, indptr), shape=A.shape).toarray() != 0
    assert np.array_equal(got, want) and (got == got.T).all()


def _stretched_voxels(theta):
    """The first aggregates of ``K + M`` on voxels 1 x 1 x 6, with each vertex's slice."""
    from ndboundary import ImageGrid

    grid = ImageGrid((10, 10, 6), spacing=(1.0, 1.0, 6.0))
    A = (grid.K + sp.diags(grid.mass)).tocsr()
    slice_of = np.unravel_index(np.arange(grid.n_vertices), (11, 11, 7))[2]
    return A, amg_hierarchy.energy_hierarchy(A, theta=theta)[0].aggregates, slice_of


def test_aggregates_over_strong_couplings_stay_within_the_slices_of_stretched_voxels():
    A, agg, slice_of = _stretched_voxels(amg.AMG_STRENGTH)
    spans = [np.unique(slice_of[agg == a]).size for a in range(agg.max() + 1)]
    assert max(spans) == 1
    _, agg0, _ = _stretched_voxels(0.0)  # every coupling: aggregates cross the slices
    assert max(np.unique(slice_of[agg0 == a]).size for a in range(agg0.max() + 1)) > 1
    # the same aggregates as pyamg's standard aggregation of the strong pattern
    _skip_unless_available("amg")
    from pyamg.aggregation.aggregate import standard_aggregation

    indptr, indices = amg_hierarchy.strong_pattern(A, amg.AMG_STRENGTH)
    C = sp.csr_matrix((np.ones(indices.size), indices, indptr), shape=A.shape)
    AggOp = sp.csr_matrix(standard_aggregation(C)[0])
    ref = np.full(A.shape[0], -1)
    ref[np.repeat(np.arange(A.shape[0]), np.diff(AggOp.indptr))] = AggOp.indices
    assert np.array_equal(agg, ref)


def test_strong_aggregation_cuts_the_integration_iterations_on_thick_slices(monkeypatch):
    from ndboundary import relax_image

    i, j, k = np.indices((40, 40, 10))
    x = np.stack([(i - 19.3) * 0.6, (j - 19.6) * 0.6, (k - 4.4) * 4.0], axis=-1)
    mask = np.linalg.norm(x, axis=-1) < 9.0
    # the integration to 1e-7: at its default 1e-5 the slower iteration over every coupling
    # stops 3e-4 h away from the solution
    strong = relax_image(mask, spacing=(0.6, 0.6, 4.0), rtol=1e-9)
    monkeypatch.setattr(amg, "AMG_STRENGTH", 0.0)
    every = relax_image(mask, spacing=(0.6, 0.6, 4.0), rtol=1e-9)
    assert strong.solver["integration"].method == "pcg-amg"
    assert strong.solver["integration"].iterations < 0.5 * every.solver["integration"].iterations
    np.testing.assert_allclose(strong.phi, every.phi, atol=1e-4)


def test_products_on_several_threads_change_no_bit_of_the_relaxation(monkeypatch):
    """The solvers multiply by the stiffness on several threads in blocks of rows, each row
    summed in scipy's order: the relaxation is the same to the last bit as on one thread."""
    from ndboundary import PointCloud, _compiled, relax

    # two blocks of rows whatever the machine, or the tests before, allow (OMP_NUM_THREADS)
    monkeypatch.setattr(_compiled, "available_threads", lambda: 2)
    X = np.random.default_rng(0).normal(size=(1500, 6))
    labels = X[:, 0] + 0.5 * X[:, 1] ** 2 > 0.3
    cloud = PointCloud(X)
    monkeypatch.setattr(_compiled, "MIN_ENTRIES_PER_ROW", 1)
    monkeypatch.setattr(_compiled, "MIN_ENTRIES_PER_THREAD", 1000)
    assert len(_compiled.ThreadedMatvec(cloud.K).blocks) > 1
    threaded = relax(cloud, labels, on="vertices", band=None)
    monkeypatch.setattr(_compiled, "MIN_ENTRIES_PER_THREAD", 10**12)
    single = relax(cloud, labels, on="vertices", band=None)
    np.testing.assert_array_equal(threaded.phi, single.phi)
    np.testing.assert_array_equal(threaded.u, single.u)


def test_cvxopt_factorisations_on_two_threads_keep_their_options_and_solve():
    # the relaxation factorises beside its field: two factorisations may overlap
    _skip_unless_available("cvxopt")
    import cvxopt.cholmod

    before = dict(cvxopt.cholmod.options)
    systems = []
    for n in (20, 24, 28, 32):
        K, mass, S = _system(n, 2)
        A = (K @ sp.diags(1 / mass) @ K + 0.1 * K + S.T @ S).tocsr()
        systems.append((A, np.random.default_rng(n).standard_normal(A.shape[0])))
    with ThreadPoolExecutor(2) as pool:
        solves = list(pool.map(lambda sys_: solvers.factorize_spd(sys_[0], backend="cvxopt"), systems))
    for (A, b), solve in zip(systems, solves, strict=True):
        assert np.linalg.norm(A @ solve(b) - b) < 1e-9 * np.linalg.norm(b)
    assert dict(cvxopt.cholmod.options) == before
