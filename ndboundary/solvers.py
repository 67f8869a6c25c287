"""Linear solvers for the two systems of the relaxation.

* Heat, ``(M + t K) u = b`` with ``t = h^2``: mass dominated, its conditioning does
  not grow with the mesh, so Jacobi-preconditioned conjugate gradients converge in a
  few dozen iterations at any size.
* Integration, ``Q phi = r`` with ``Q = K M^{-1} K + mu K + lam S^T S`` (a squared
  Laplacian). Two ways, chosen by the shape of ``K`` (``method="auto"``):

  - sparse rows (triangle meshes, surfaces: about 7 entries per row of ``K``) or small
    systems: a sparse Cholesky factorisation of ``Q`` itself, CHOLMOD (package
    ``sksparse-minimal``, an optional accelerator: as fast as SuperLU on flat meshes,
    about 2x faster on closed surfaces) when installed, else scipy's SuperLU;
  - denser rows (tetrahedra, higher dimensions, neighbour graphs): conjugate gradients
    preconditioned by ``(K + D) M^{-1} (K + D)``, ``D`` diagonal, ``(K + D)^{-1}``
    applied by one smoothed-aggregation AMG V-cycle (package ``pyamg``: linear cost,
    where any factorisation of a 3-D mesh fills in as n^2: 4 s instead of 40-275 s at
    118K vertices), else by a Cholesky factor, with one :class:`SolverFallbackWarning`
    per process naming the cost.

Every solve reports its relative residual; an iteration that does not reach its
tolerance warns with the residual it reached (``method="pcg"``) or finishes with a
direct factorisation (``method="auto"``).

Solves run with one BLAS thread (threadpoolctl): OpenBLAS's threads spin on the short
vector operations of conjugate gradients and cost 1.5-4x the wall time on a 2-core
machine with any other load; the sparse kernels used here are single-threaded anyway.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = [
    "SolveInfo",
    "SolverFallbackWarning",
    "available_backends",
    "clear_cache",
    "factorize_spd",
    "solve_heat",
    "solve_integration",
]

#: Rows of ``K`` with more entries than this on average count as "3-D like": the
#: integration then iterates instead of factorising ``Q`` (whose fill grows as n^2).
DENSE_ROW_THRESHOLD = 10.0
#: Below this many unknowns the integration system is always factorised.
SMALL_SYSTEM = 3000

#: Speed cost of the fallback when an optional package that "auto" relies on is missing,
#: as measured by ``benchmarks/solvers.py``. (sksparse-minimal is a silent accelerator:
#: without it SuperLU is as fast on flat triangle meshes, up to 2x slower on closed
#: surfaces and in the factorised preconditioner.)
_FALLBACK_COST = {
    "pyamg": (
        "pyamg is not installed: the integration solve on tetrahedral (3-D) meshes falls back "
        "to a sparse factorisation, about 5x slower at 36K vertices and 10-20x at 120K "
        "(pip install pyamg)"
    ),
}
_warned: set = set()


class SolverFallbackWarning(UserWarning):
    """An optional fast solver package is missing; a slower pure-scipy path is used."""


@dataclass
class SolveInfo:
    """What a solve did: its method, iteration count and the relative residual reached.

    ``setup_time`` and ``solve_time`` (seconds) split the wall time between building
    the factorisation or preconditioner and applying it.
    """

    method: str
    iterations: int
    residual: float
    setup_time: float = field(default=0.0, compare=False)
    solve_time: float = field(default=0.0, compare=False)


# ----------------------------------------------------------------------------- helpers


def _load(name):
    """The optional module ``name``, or None when it cannot be imported."""
    try:
        return importlib.import_module(name)
    except Exception:  # noqa: BLE001 - ImportError, or a broken binary wheel
        return None


def _fallback_warning(name):
    """Warn, once per process, that a pure-scipy path replaces the missing package ``name``."""
    if name in _warned:
        return
    _warned.add(name)
    warnings.warn(_FALLBACK_COST[name], SolverFallbackWarning, stacklevel=4)


def available_backends():
    """Names of the factorisation / preconditioner backends importable here."""
    out = ["superlu"]
    if _load("sksparse_minimal") is not None:
        out.insert(0, "cholmod")
    if _load("pyamg") is not None:
        out.append("amg")
    return out


def _one_blas_thread():
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl ships with scikit-learn
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def _superlu(A):
    lu = spla.splu(
        sp.csc_matrix(A),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve


def _cholmod(A):
    mod = _load("sksparse_minimal")
    A = sp.csc_matrix(A)
    A.sort_indices()
    A = sp.csc_matrix(
        (A.data.astype(np.float64), A.indices.astype(np.int32), A.indptr.astype(np.int32)),
        shape=A.shape,
    )
    factor = mod.SparseCholesky(A)
    return factor.solve_A


def factorize_spd(A, backend="auto"):
    """Return a function solving ``A x = b`` for a sparse symmetric positive definite ``A``.

    Parameters
    ----------
    backend : {"auto", "cholmod", "superlu"}, default="auto"
        ``"cholmod"``: CHOLMOD supernodal Cholesky with METIS/AMD ordering (package
        ``sksparse-minimal``); ``"superlu"``: scipy's SuperLU in symmetric mode
        (minimum degree on ``A + A^T``, diagonal pivots); ``"auto"``: cholmod when
        installed (falling back to SuperLU if CHOLMOD rejects the matrix), else SuperLU.
    """
    if backend not in ("auto", "cholmod", "superlu"):
        raise ValueError(f"backend must be 'auto', 'cholmod' or 'superlu', got {backend!r}")
    if backend == "superlu":
        return _superlu(A)
    if _load("sksparse_minimal") is None:
        if backend == "cholmod":
            raise ImportError("backend='cholmod' needs the package sksparse-minimal")
        return _superlu(A)
    try:
        return _cholmod(A)
    except Exception:
        if backend == "cholmod":
            raise
        return _superlu(A)


def _amg(A):
    pyamg = _load("pyamg")
    smoother = ("gauss_seidel", {"sweep": "symmetric", "iterations": 2})
    ml = pyamg.smoothed_aggregation_solver(
        sp.csr_matrix(A),
        symmetry="symmetric",
        smooth="energy",
        presmoother=smoother,
        postsmoother=smoother,
        max_coarse=500,
    )
    P = ml.aspreconditioner(cycle="V")  # symmetric smoothers: an SPD operator
    return P.matvec


# A one-entry cache of the last factorisation / preconditioner, keyed by the content of
# the matrix: a second relax() on the same domain, labels and lam reuses it.
_cache: dict = {}


def clear_cache():
    """Drop the cached factorisation (it holds memory of the order of the factor)."""
    _cache.clear()


def _key(kind, A):
    A = sp.csr_matrix(A)
    h = hashlib.blake2b(digest_size=16)
    h.update(repr((kind, A.shape, A.nnz)).encode())
    for arr in (A.indptr, A.indices, A.data):
        h.update(np.ascontiguousarray(arr).view(np.uint8))
    return h.hexdigest()


def _cached(kind, A, build, cache):
    if not cache:
        return build(A)
    key = _key(kind, A)
    entry = _cache.get("entry")  # one (key, value) tuple: safe to read from any thread
    if entry is not None and entry[0] == key:
        return entry[1]
    _cache.clear()  # free the old one before building the new one
    value = build(A)
    _cache["entry"] = (key, value)
    return value


def _relres(A, x, b):
    nb = np.linalg.norm(b)
    return float(np.linalg.norm(A @ x - b) / nb) if nb > 0 else 0.0


def _cg(A, b, M, rtol, maxiter, x0=None):
    it = [0]

    def count(_):
        it[0] += 1

    with _one_blas_thread():
        x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=maxiter, M=M, callback=count)
    return x, it[0], info


# ----------------------------------------------------------------------------- heat


def solve_heat(mass, K, t, b, *, rtol=1e-10, maxiter=2000):
    """Solve ``(diag(mass) + t K) u = b`` by Jacobi-preconditioned conjugate gradients."""
    t0 = time.perf_counter()
    A = (sp.diags(mass) + t * K).tocsr()
    dinv = 1.0 / A.diagonal()
    P = spla.LinearOperator(A.shape, matvec=lambda r: dinv * r, dtype=np.float64)
    t1 = time.perf_counter()
    u, iters, info = _cg(A, b, P, rtol, maxiter)
    res = _relres(A, u, b)
    if info != 0 and res > 10 * rtol:
        with _one_blas_thread():
            u = factorize_spd(A)(b)
        res2 = _relres(A, u, b)
        return u, SolveInfo("cholesky", iters, res2, t1 - t0, time.perf_counter() - t1)
    return u, SolveInfo("cg-jacobi", iters, res, t1 - t0, time.perf_counter() - t1)


# ----------------------------------------------------------------------------- integration


def _is_sparse_rows(K):
    n = K.shape[0]
    return n <= SMALL_SYSTEM or K.nnz / max(n, 1) <= DENSE_ROW_THRESHOLD


def _direct(Q, rhs, backend, cache, iters=0):
    t0 = time.perf_counter()
    with _one_blas_thread():
        solve = _cached(("direct", backend), Q, lambda A: factorize_spd(A, backend=backend), cache)
        t1 = time.perf_counter()
        phi = solve(rhs)
    t2 = time.perf_counter()
    return phi, SolveInfo("cholesky", iters, _relres(Q, phi, rhs), t1 - t0, t2 - t1)


def solve_integration(
    K,
    mass,
    S,
    lam,
    rhs,
    *,
    mu=0.0,
    rtol=1e-10,
    maxiter=200,
    method="auto",
    backend="auto",
    preconditioner="auto",
    cache=True,
):
    """Solve ``(K M^{-1} K + mu K + lam S^T S) phi = rhs``.

    Parameters
    ----------
    K : sparse matrix of shape (n, n)
    mass : ndarray of shape (n,)
    S : sparse matrix of shape (m, n)
    lam : float
    rhs : ndarray of shape (n,)
    mu : float, default=0
    rtol : float, default=1e-10
        Relative residual to reach.
    maxiter : int, default=200
        Iterations allowed to conjugate gradients.
    method : {"auto", "pcg", "direct"}, default="auto"
        ``"direct"``: Cholesky factorisation of the whole matrix. ``"pcg"``: conjugate
        gradients preconditioned by ``(K + D) M^{-1} (K + D)``; warns if it does not
        converge in ``maxiter`` iterations. ``"auto"``: direct on meshes with sparse rows
        (about 7 entries per row of ``K``: triangles, surfaces) or small systems, pcg
        elsewhere (tetrahedra, higher dimensions, graphs), falling back to direct when
        pcg does not converge.
    backend : {"auto", "cholmod", "superlu"}, default="auto"
        Sparse Cholesky used by the direct solve and the factorised preconditioner
        (see :func:`factorize_spd`).
    preconditioner : {"auto", "amg", "cholesky"}, default="auto"
        How pcg applies ``(K + D)^{-1}``: one AMG V-cycle (package ``pyamg``) or a
        sparse Cholesky factor. ``"auto"``: amg on meshes with denser rows when pyamg
        is installed, cholesky otherwise.
    cache : bool, default=True
        Keep the last factorisation / AMG hierarchy and reuse it when the same matrix
        comes again (compared by content); :func:`clear_cache` frees it.

    Returns
    -------
    phi : ndarray of shape (n,)
    info : SolveInfo
        ``method`` is ``"cholesky"`` or ``"pcg-amg"`` / ``"pcg-cholesky"``.
    """
    if method not in ("auto", "pcg", "direct"):
        raise ValueError(f"method must be 'auto', 'pcg' or 'direct', got {method!r}")
    if preconditioner not in ("auto", "amg", "cholesky"):
        raise ValueError(
            f"preconditioner must be 'auto', 'amg' or 'cholesky', got {preconditioner!r}"
        )
    K = sp.csr_matrix(K)
    mass = np.asarray(mass, dtype=np.float64)
    S = sp.csr_matrix(S)
    rhs = np.asarray(rhs, dtype=np.float64)

    def assemble():
        Q = (K @ sp.diags(1.0 / mass) @ K + mu * K + lam * (S.T @ S)).tocsr()
        return ((Q + Q.T) * 0.5).tocsr()

    sparse_rows = _is_sparse_rows(K)
    if method == "direct" or (method == "auto" and sparse_rows):
        t0 = time.perf_counter()
        Q = assemble()
        phi, info = _direct(Q, rhs, backend, cache)
        info.setup_time = time.perf_counter() - t0 - info.solve_time  # with the assembly
        return phi, info

    # (K + D) M^{-1} (K + D), D = mu/2 M + C, C M^{-1} C = lam diag(S^T S): mu K and the
    # constraint's diagonal are matched exactly, the squared Laplacian exactly off it.
    t0 = time.perf_counter()
    sts = np.asarray(abs(S).T @ abs(S) @ np.ones(S.shape[1])).ravel()
    d = 0.5 * mu * mass + np.sqrt(lam * sts * mass)
    A = (K + sp.diags(d)).tocsr()
    if preconditioner == "auto":
        use_amg = not sparse_rows
        if use_amg and _load("pyamg") is None:
            _fallback_warning("pyamg")
            use_amg = False
    elif preconditioner == "amg":
        if _load("pyamg") is None:
            raise ImportError("preconditioner='amg' needs the package pyamg")
        use_amg = True
    else:
        use_amg = False
    name = "pcg-amg" if use_amg else "pcg-cholesky"
    with _one_blas_thread():
        if use_amg:
            solve = _cached("amg", A, _amg, cache)
        else:
            solve = _cached(
                ("factor", backend), A, lambda B: factorize_spd(B, backend=backend), cache
            )

    def apply(r):
        return solve(mass * solve(r))

    # Q applied as K M^{-1} K + mu K + lam S^T S, never assembled: two products with K
    # cost less than one with Q (2-ring stencil), and the sparse product is skipped.
    minv = 1.0 / mass
    St = S.T.tocsr()

    def qmul(x):
        Kx = K @ x
        return K @ (minv * Kx) + mu * Kx + lam * (St @ (S @ x))

    n = K.shape[0]
    Q = spla.LinearOperator((n, n), matvec=qmul, dtype=np.float64)
    P = spla.LinearOperator((n, n), matvec=apply, dtype=np.float64)
    t1 = time.perf_counter()
    phi, iters, info = _cg(Q, rhs, P, rtol, maxiter)
    res = _relres(Q, phi, rhs)
    t2 = time.perf_counter()
    if info != 0 and res > 10 * rtol:
        if method == "pcg":
            warnings.warn(
                f"integration solve did not converge in {iters} iterations "
                f"(relative residual {res:.2e}, target {rtol:.0e})",
                RuntimeWarning,
                stacklevel=2,
            )
            return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)
        phi, info2 = _direct(assemble(), rhs, backend, cache, iters)
        info2.setup_time += t2 - t0
        return phi, info2
    return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)
