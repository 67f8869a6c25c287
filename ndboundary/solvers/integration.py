"""The integration system ``Q phi = r``, ``Q = K M^{-1} K + mu K + lam S^T S`` (a
squared Laplacian): :func:`solve_integration`; and its first-order form ``(K + lam S^T
S) phi = r``: :func:`solve_gradient_integration`.

Two ways, chosen by the shape of ``K`` (``method="auto"``):

- sparse rows (triangle meshes, surfaces: about 7 entries per row of ``K``) or small
  systems: a sparse Cholesky factorisation of ``Q`` itself by the fastest installed
  backend (:func:`~ndboundary.solvers.factorize_spd`). From
  :data:`SINGLE_PRECISION_MIN` unknowns with PARDISO, the factor is computed in single
  precision and conjugate gradients preconditioned by it refine the solution to
  ``rtol``: half the factor's memory and a faster factorisation. Without a fast
  backend scipy's SuperLU factorises, several times slower, with one
  :class:`~ndboundary.solvers.SolverFallbackWarning` per process naming the cost.
- denser rows (tetrahedra, higher dimensions, neighbour graphs): conjugate gradients
  preconditioned by ``(K + D) M^{-1} (K + D)``, ``D`` diagonal, ``(K + D)^{-1}``
  applied by one smoothed-aggregation AMG V-cycle with a Jacobi step on the light
  vertices around it (:mod:`.amg`, package pyamg: linear cost, where any factorisation
  of a 3-D mesh fills in as n^2), or by a Cholesky factor on smaller systems and
  neighbour graphs (:data:`PCG_FACTOR_MAX`) or without pyamg (with one
  :class:`~ndboundary.solvers.SolverFallbackWarning` per process naming the cost).

Every solve reports its relative residual; an iteration that does not reach its
tolerance warns with the residual it reached (``method="pcg"``) or finishes with a
direct factorisation (``method="auto"``). The timings behind these choices are
measured by ``benchmarks/solvers.py`` (figures in the README).
"""

from __future__ import annotations

import functools
import time
import warnings
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._compiled import ThreadedMatvec, plus_diagonal, squared_upper
from .amg import AMG_DENSE_ROWS, amg_preconditioner, light_vertex_jacobi
from .cache import cached, orderings_of
from .cholesky import LARGE_SYSTEM, factorize_spd, fast_cholesky_available
from .common import (
    ConvergenceWarning,
    SolveInfo,
    cg,
    fallback_warning,
    load_optional,
    one_blas_thread,
    relres,
    warn_unconverged,
)
from . import pardiso
from .pardiso import PardisoFactor, refined_single

__all__ = [
    "DENSE_ROW_THRESHOLD",
    "DIRECT_FALLBACK_MAX",
    "SINGLE_PRECISION_MIN",
    "SINGLE_REFINE_MAXITER",
    "PCG_FACTOR_MAX",
    "PCG_FACTOR_MAX_GRAPHS",
    "SMALL_SYSTEM",
    "Preconditioner",
    "IntegrationFactor",
    "integration_preconditioner",
    "solve_gradient_integration",
    "solve_integration",
]

#: Rows of ``K`` with more entries than this on average count as "3-D like": the
#: integration then iterates instead of factorising ``Q`` (whose fill grows as n^2).
#: Triangle meshes and surfaces have about 7 entries per row, tetrahedral meshes 14.
DENSE_ROW_THRESHOLD = 10.0
#: Up to this many unknowns the integration system is always factorised: the
#: factorisation of a small system is cheap whatever its fill.
SMALL_SYSTEM = 1000
#: Up to this many unknowns (:data:`PCG_FACTOR_MAX_GRAPHS` where the rows of ``K`` hold
#: more than :data:`~ndboundary.solvers.amg.AMG_DENSE_ROWS` entries: neighbour graphs),
#: pcg on dense rows is preconditioned by a Cholesky factor of ``K + D``, not an AMG
#: V-cycle: the factor is cheap there, and on graphs of data of high intrinsic dimension
#: the V-cycle stalls (``benchmarks/fit_speed.py``, figures in the README).
PCG_FACTOR_MAX = 4000
#: See :data:`PCG_FACTOR_MAX`.
PCG_FACTOR_MAX_GRAPHS = 20_000
#: From this many unknowns, ``method="auto"`` factorises the integration matrix of a
#: triangle mesh with PARDISO in single precision (half the factor's memory, a faster
#: factorisation) and refines the solution by conjugate gradients preconditioned with
#: that factor to ``rtol``; if that takes more than :data:`SINGLE_REFINE_MAXITER`
#: iterations, a double-precision factor solves it instead. The same size as
#: :data:`~ndboundary.solvers.cholesky.LARGE_SYSTEM`, from where PARDISO is the backend
#: tried first.
SINGLE_PRECISION_MIN = LARGE_SYSTEM
#: Iterations allowed to the refinement of a single-precision factor: it converges in
#: a handful, so needing many means the factor is too inaccurate for this system.
SINGLE_REFINE_MAXITER = 30
#: Above this many unknowns, a system with denser rows whose iteration stalls is not
#: factorised (its factor fills in as n^2: minutes of factorisation, and more memory
#: than a workstation has at a million vertices); conjugate gradients go on for
#: ``4 maxiter`` more iterations instead, then warn with the residual reached.
DIRECT_FALLBACK_MAX = 120_000


class _System(NamedTuple):
    """The arguments of :func:`solve_integration` that define the system, converted."""

    K: sp.csr_matrix
    mass: np.ndarray
    S: sp.csr_matrix
    lam: float
    mu: float
    rhs: np.ndarray


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
    sweeps=2,
    cache=None,
    x0=None,
):
    """Solve ``(K M^{-1} K + mu K + lam S^T S) phi = rhs``.

    Parameters
    ----------
    K : sparse matrix of shape (n, n)
        Stiffness matrix, symmetric positive semidefinite.
    mass : ndarray of shape (n,)
        Diagonal of the (lumped) mass matrix ``M``, positive.
    S : sparse matrix of shape (m, n)
        Constraint rows: ``S phi`` is held close to the data by the weight ``lam``.
    lam : float
        Weight of the constraint ``lam S^T S``.
    rhs : ndarray of shape (n,)
        Right-hand side.
    mu : float, default=0
        Weight of the ``mu K`` term (membrane energy next to the bending energy of the
        squared Laplacian); 0 solves the squared Laplacian alone.
    rtol : float, default=1e-10
        Relative residual to reach: tight, so that the level set of ``phi`` does not
        move with the solver's error.
    maxiter : int, default=200
        Iterations allowed to conjugate gradients: headroom over what the
        AMG-preconditioned iteration needs on meshes of a million vertices, while a
        stalled iteration still hands over to a factorisation soon.
    method : {"auto", "pcg", "direct"}, default="auto"
        ``"direct"``: Cholesky factorisation of the whole matrix. ``"pcg"``: conjugate
        gradients preconditioned by ``(K + D) M^{-1} (K + D)``; warns if it does not
        converge in ``maxiter`` iterations. ``"auto"``: direct on meshes with sparse rows
        (about 7 entries per row of ``K``: triangles, surfaces) or small systems (from
        :data:`SINGLE_PRECISION_MIN` unknowns with PARDISO, a single-precision factor
        refined by conjugate gradients to ``rtol``: method ``"cholesky-single+cg"``), pcg
        elsewhere (tetrahedra, higher dimensions, graphs), falling back to direct when
        pcg does not converge (up to :data:`DIRECT_FALLBACK_MAX` unknowns; beyond, pcg
        goes on for ``4 maxiter`` more iterations and warns if that is not enough). The
        default picks the fastest way for the shape of ``K``, on a band's system as on the
        whole domain's (``benchmarks/solvers.py``).
    backend : {"auto", "pardiso", "cvxopt", "cholmod", "superlu"}, default="auto"
        Sparse Cholesky used by the direct solve and the factorised preconditioner
        (see :func:`~ndboundary.solvers.factorize_spd`; ``"auto"``: the fastest
        installed). With ``"auto"`` and none of the optional backends installed, a
        direct solve of more than :data:`SMALL_SYSTEM` unknowns warns once per process
        (:class:`~ndboundary.solvers.SolverFallbackWarning`).
    preconditioner : {"auto", "amg", "cholesky"}, Preconditioner or IntegrationFactor, default="auto"
        How pcg applies ``(K + D)^{-1}``: one AMG V-cycle (package ``pyamg``) with a
        Jacobi step on the light vertices before and after it
        (:func:`~ndboundary.solvers.amg.light_vertex_jacobi`), or a sparse Cholesky
        factor. ``"auto"``: amg on meshes with denser rows when pyamg is installed (its
        cost grows linearly, where the factor fills in), cholesky otherwise. A
        :class:`Preconditioner` built for this system by
        :func:`integration_preconditioner` is used as it is, and so is an
        :class:`IntegrationFactor` (the factor of the direct path), which solves at once.
    sweeps : int, default=2
        Gauss-Seidel sweeps of the AMG V-cycle on each level, before the coarse
        correction and after it (:func:`~ndboundary.solvers.amg.amg_preconditioner`).
    cache : FactorCache, optional
        Where to keep the factorisation / AMG hierarchy for the next solve of the same
        matrix (compared by content) and PARDISO's ordering for the same pattern. None,
        the default, keeps nothing: a one-shot solve holds no memory once it returns.
    x0 : ndarray of shape (n,), optional
        Where conjugate gradients start (the solution of a nearby system); a direct
        solve has no use for it.

    Returns
    -------
    phi : ndarray of shape (n,)
    info : SolveInfo
        ``method`` is ``"cholesky"``, ``"cholesky-single+cg"`` or ``"pcg-amg"`` /
        ``"pcg-cholesky"``.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> K = sp.csr_matrix([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> mass = np.ones(3)
    >>> S = sp.csr_matrix([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # hold both ends
    >>> rhs = np.array([1.0, 0.0, -1.0])
    >>> phi, info = solve_integration(K, mass, S, 2.0, rhs, mu=0.1)
    >>> Q = (K @ K + 0.1 * K + 2.0 * (S.T @ S)).toarray()
    >>> bool(np.allclose(phi, np.linalg.solve(Q, rhs))), info.method, info.residual < 1e-10
    (True, 'cholesky', True)
    >>> phi2, info2 = solve_integration(K, mass, S, 2.0, rhs, mu=0.1, method="pcg", preconditioner="cholesky")
    >>> bool(np.allclose(phi2, phi)), info2.method
    (True, 'pcg-cholesky')
    """
    _check_choices(method, preconditioner)
    if isinstance(preconditioner, IntegrationFactor):
        return _solve_factored(preconditioner, np.asarray(rhs, dtype=np.float64), rtol)
    K, S = sp.csr_matrix(K), sp.csr_matrix(S)
    system = _System(K, np.asarray(mass, dtype=np.float64), S, lam, mu, np.asarray(rhs, dtype=np.float64))
    sparse_rows = _is_sparse_rows(K)
    if method == "direct" or (method == "auto" and sparse_rows):
        return _solve_direct(system, rtol, refine_single=method == "auto", backend=backend, cache=cache)
    return _solve_pcg(
        system, rtol, maxiter, fall_back=method == "auto", sparse_rows=sparse_rows,
        backend=backend, preconditioner=preconditioner, sweeps=sweeps, cache=cache, x0=x0,
    )  # fmt: skip


# ----------------------------------------------------------------------------- direct


def _solve_direct(system, rtol, *, refine_single, backend, cache):
    """The direct path: factorise ``Q`` (in single precision refined by conjugate
    gradients when ``refine_single`` and the system is large enough for PARDISO's).
    """
    if backend == "auto" and system.K.shape[0] > SMALL_SYSTEM and not fast_cholesky_available():
        # stacklevel 5: past this function and solve_integration, at the pipeline's caller
        fallback_warning("cholesky", stacklevel=5)
    t0 = time.perf_counter()
    Q = _assemble(system, cache)
    single = None
    if _refines_single(refine_single, backend, Q.shape[0]):
        single = refined_single(Q, system.rhs, rtol, cache, SINGLE_REFINE_MAXITER)
    phi, info = single if single is not None else _factor_solve(Q, system.rhs, backend, cache)
    info.setup_time = time.perf_counter() - t0 - info.solve_time  # with the assembly
    if not info.residual <= 10 * rtol:
        # stacklevel 4: past this function and solve_integration, at the pipeline's caller
        warn_unconverged("integration (step 4)", info, rtol, " (the factorisation lost its accuracy)", stacklevel=4)
    return phi, info


def _assemble(system, cache=None):
    """``Q`` as a CSR matrix, symmetrised against rounding; ``K M^{-1} K + mu K`` taken
    from ``cache`` when it holds it (:meth:`FactorCache.squared`).
    """
    K, mass, S, lam, mu, _rhs = system

    def squared():
        P = (K @ sp.diags(1.0 / mass) @ K + mu * K).tocsr()
        return ((P + P.T) * 0.5).tocsr()

    P = squared() if cache is None else cache.squared(K, mass, mu, squared)
    return (P + lam * (S.T @ S)).tocsr()


def _factor(kind, A, backend, cache):
    """The solve of a Cholesky factor of ``A`` (:func:`~ndboundary.solvers.factorize_spd`),
    kept in ``cache`` as ``kind`` (with PARDISO's ordering for the pattern).
    """
    return cached(kind, A, lambda B: factorize_spd(B, backend=backend, orderings=orderings_of(cache)), cache)


def _refines_single(refine_single, backend, n):
    """Whether the direct path factorises in single precision (PARDISO) and refines."""
    return refine_single and backend in ("auto", "pardiso") and n >= SINGLE_PRECISION_MIN and pardiso.available()


def _solve_factored(factor, rhs, rtol):
    """The direct path's solve with its factor built before (:class:`IntegrationFactor`)."""
    t0 = time.perf_counter()
    with one_blas_thread():
        phi = factor.solve(rhs)
    info = SolveInfo("cholesky", 0, relres(factor.Q, phi, rhs), factor.setup_time, time.perf_counter() - t0)
    if not info.residual <= 10 * rtol:
        # stacklevel 4: past this function and solve_integration, at the pipeline's caller
        warn_unconverged("integration (step 4)", info, rtol, " (the factorisation lost its accuracy)", stacklevel=4)
    return phi, info


def _factor_solve(Q, rhs, backend, cache, iters=0):
    """Solve ``Q phi = rhs`` by a double-precision Cholesky factor of ``Q`` (reported
    with the ``iters`` iterations that came before it).
    """
    t0 = time.perf_counter()
    with one_blas_thread():
        solve = _factor(("direct", backend), Q, backend, cache)
        t1 = time.perf_counter()
        phi = solve(rhs)
    t2 = time.perf_counter()
    return phi, SolveInfo("cholesky", iters, relres(Q, phi, rhs), t1 - t0, t2 - t1)


# ----------------------------------------------------------------------------- pcg


def _solve_pcg(system, rtol, maxiter, *, fall_back, sparse_rows, backend, preconditioner, sweeps, cache, x0=None):
    """The iterative path: conjugate gradients preconditioned by ``(K + D) M^{-1} (K + D)``
    (``preconditioner`` itself when it is a :class:`Preconditioner`).

    When the iteration stalls, ``fall_back`` (``method="auto"``) factorises ``Q``, or
    iterates on for systems too large to factorise; otherwise it warns.
    """
    K, mass, S, lam, mu, rhs = system
    t0 = time.perf_counter()
    if isinstance(preconditioner, Preconditioner):  # built before: its setup counts as this solve's
        t0 -= preconditioner.setup_time
    else:
        preconditioner = _preconditioner(system, sparse_rows, backend, preconditioner, sweeps, cache)
    apply, name = preconditioner.apply, preconditioner.method
    n = K.shape[0]
    Q = _q_operator(system)
    P = spla.LinearOperator((n, n), matvec=apply, dtype=np.float64)
    t1 = time.perf_counter()
    phi, iters, info = cg(Q, rhs, P, rtol, maxiter, x0=x0)
    res = relres(Q, phi, rhs)
    t2 = time.perf_counter()
    if info != 0 and res > 10 * rtol:
        if not fall_back:
            warnings.warn(
                f"integration solve did not converge in {iters} iterations "
                f"(relative residual {res:.2e}, target {rtol:.0e})",
                ConvergenceWarning,
                stacklevel=3,  # the caller of solve_integration
            )
            return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)
        if sparse_rows or n <= DIRECT_FALLBACK_MAX:
            phi, info2 = _factor_solve(_assemble(system, cache), rhs, backend, cache, iters)
            info2.setup_time += t2 - t0
            return phi, info2
        phi, iters, res = _iterate_on(Q, P, system, phi, iters, rtol, maxiter)
        t2 = time.perf_counter()
    return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)


class Preconditioner(NamedTuple):
    """The preconditioner of :func:`solve_integration`'s conjugate gradients, built by
    :func:`integration_preconditioner` ahead of the right-hand side.

    ``apply(r)`` applies ``(K + D)^{-1} M (K + D)^{-1}``; ``method`` is the solve's
    ``"pcg-amg"`` or ``"pcg-cholesky"``; ``setup_time`` the seconds it took to build
    (reported as the solve's setup).
    """

    apply: object
    method: str
    setup_time: float


class _SymmetricUpper:
    """A symmetric matrix held by its upper triangle ``U`` (CSR): ``Q @ x`` is
    ``U x + U^T x - diag(U) x``, without the lower triangle.
    """

    def __init__(self, U):
        self.U, self.shape, self._diagonal = U, U.shape, U.diagonal()

    def __matmul__(self, x):
        return self.U @ x + self.U.T @ x - self._diagonal * x


class IntegrationFactor(NamedTuple):
    """The double-precision Cholesky factor of ``Q`` that :func:`solve_integration`'s
    direct path computes, built by :func:`integration_preconditioner` ahead of the
    right-hand side: ``solve(b)`` solves ``Q x = b``; ``setup_time`` the seconds the
    assembly of ``Q`` and its factorisation took (reported as the solve's setup). ``Q``
    is the matrix, or an operator that multiplies by it (``Q @ x``; its upper triangle,
    which is all PARDISO reads, when built beside other work).
    """

    Q: object
    solve: object
    setup_time: float


def integration_preconditioner(
    K,
    mass,
    S,
    lam,
    *,
    mu=0.0,
    method="auto",
    backend="auto",
    preconditioner="auto",
    sweeps=2,
    cache=None,
    concurrent=False,
):
    """Build the AMG preconditioner :func:`solve_integration` would build for this
    system, before its right-hand side is known: the relaxation builds it beside the steps
    that compute the field (which only the right-hand side reads). Its arguments are those
    of :func:`solve_integration`, and ``concurrent``: whether it runs beside that Python
    work, on another thread. The direct path then assembles ``Q``'s upper triangle in
    one compiled call and factorises it by PARDISO where installed, both without holding
    the GIL, so that the work beside goes on; the CHOLMOD of cvxopt (the fastest
    otherwise) and the sparse products of the assembly hold it.

    Returns
    -------
    Preconditioner, IntegrationFactor or None
        An :class:`IntegrationFactor` when :func:`solve_integration` factorises ``Q``
        (``method="direct"``, or ``"auto"`` on sparse rows) in double precision with a
        fast backend: then the solve only solves. None when it factorises ``K + D`` for
        the iteration (small systems, ``preconditioner="cholesky"``, or without pyamg),
        and when it factorises ``Q`` in single precision (PARDISO, from
        :data:`SINGLE_PRECISION_MIN` unknowns) or without a fast backend (the solve warns
        of the cost).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> n = 50  # a path held at both ends
    >>> K = sp.diags([-np.ones(n - 1), np.r_[1.0, 2.0 * np.ones(n - 2), 1.0], -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    >>> S = sp.csr_matrix(([1.0, 1.0], ([0, 1], [0, n - 1])), shape=(2, n))
    >>> rhs = np.linspace(-1.0, 1.0, n)
    >>> pre = integration_preconditioner(K, np.ones(n), S, 1.0, method="pcg", preconditioner="amg")
    >>> phi, info = solve_integration(K, np.ones(n), S, 1.0, rhs, method="pcg", preconditioner=pre)
    >>> ref, _ = solve_integration(K, np.ones(n), S, 1.0, rhs, method="direct")
    >>> info.method, bool(np.allclose(phi, ref, atol=1e-8))
    ('pcg-amg', True)
    >>> integration_preconditioner(K, np.ones(n), S, 1.0, method="pcg", preconditioner="cholesky") is None
    True
    >>> factor = integration_preconditioner(K, np.ones(n), S, 1.0, method="direct")
    >>> phi, info = solve_integration(K, np.ones(n), S, 1.0, rhs, preconditioner=factor)
    >>> type(factor).__name__, info.method, bool(np.allclose(phi, ref, atol=1e-8))
    ('IntegrationFactor', 'cholesky', True)
    """
    _check_choices(method, preconditioner)
    K, S = sp.csr_matrix(K), sp.csr_matrix(S)
    system = _System(K, np.asarray(mass, dtype=np.float64), S, lam, mu, None)
    sparse_rows = _is_sparse_rows(K)
    if method == "direct" or (method == "auto" and sparse_rows):
        if _refines_single(method == "auto", backend, K.shape[0]) or (
            backend == "auto" and not fast_cholesky_available()
        ):
            return None
        t0 = time.perf_counter()
        if concurrent and backend in ("auto", "pardiso") and pardiso.available():
            U = squared_upper(K, system.mass, mu, S.T @ S, lam)
            try:
                with one_blas_thread():
                    solve = cached(
                        ("direct", "pardiso-upper"), U,
                        lambda A: PardisoFactor(A, upper=True, orderings=orderings_of(cache)).solve, cache,
                    )  # fmt: skip
            except RuntimeError:  # a pivot PARDISO rejects: the backends in turn, as in the solve
                if backend == "pardiso":
                    raise
            else:
                return IntegrationFactor(_SymmetricUpper(U), solve, time.perf_counter() - t0)
        Q = _assemble(system, cache)
        with one_blas_thread():
            solve = _factor(("direct", backend), Q, backend, cache)
        return IntegrationFactor(Q, solve, time.perf_counter() - t0)
    if preconditioner == "cholesky":
        return None
    if load_optional("pyamg") is None:  # the solve factorises, and warns of the cost
        return None
    if not _use_amg(preconditioner, sparse_rows, K.shape[0], K.nnz / max(K.shape[0], 1)):
        return None
    return _preconditioner(system, sparse_rows, backend, preconditioner, sweeps, cache)


def _preconditioner(system, sparse_rows, backend, preconditioner, sweeps, cache):
    """The :class:`Preconditioner` of :func:`_solve_pcg` for ``system``."""
    K, mass, S, lam, mu, _rhs = system
    # (K + D) M^{-1} (K + D), D = mu/2 M + C, C M^{-1} C = lam diag(S^T S): mu K and the
    # constraint's diagonal are matched exactly, the squared Laplacian exactly off it.
    t0 = time.perf_counter()
    sts = np.asarray(abs(S).T @ abs(S) @ np.ones(S.shape[1])).ravel()
    d = 0.5 * mu * mass + np.sqrt(lam * sts * mass)
    A = plus_diagonal(K, d)
    use_amg = _use_amg(preconditioner, sparse_rows, K.shape[0], K.nnz / max(K.shape[0], 1))
    with one_blas_thread():
        if use_amg:  # the hierarchy is kept; the light vertices' step is rebuilt from the mass
            build = functools.partial(amg_preconditioner, sweeps=sweeps)
            solve = light_vertex_jacobi(A, mass, cached(("amg", sweeps), A, build, cache))
        else:
            solve = _factor(("factor", backend), A, backend, cache)

    def apply(r):
        return solve(mass * solve(r))

    return Preconditioner(apply, "pcg-amg" if use_amg else "pcg-cholesky", time.perf_counter() - t0)


def _check_choices(method, preconditioner):
    if method not in ("auto", "pcg", "direct"):
        raise ValueError(f"method must be 'auto', 'pcg' or 'direct', got {method!r}")
    if not isinstance(preconditioner, (Preconditioner, IntegrationFactor)) and preconditioner not in (
        "auto",
        "amg",
        "cholesky",
    ):
        raise ValueError(
            "preconditioner must be 'auto', 'amg', 'cholesky', a Preconditioner or an IntegrationFactor, "
            f"got {preconditioner!r}"
        )


def _use_amg(preconditioner, sparse_rows, n, K_rows=0.0):
    """Whether pcg's preconditioner is an AMG V-cycle (else a Cholesky factor)."""
    if preconditioner == "auto":
        graph = K_rows > AMG_DENSE_ROWS
        use_amg = not sparse_rows and n > (PCG_FACTOR_MAX_GRAPHS if graph else PCG_FACTOR_MAX)
        if use_amg and load_optional("pyamg") is None:
            # stacklevel 6: past this function, _solve_pcg and solve_integration
            fallback_warning("pyamg", stacklevel=6)
            use_amg = False
        return use_amg
    if preconditioner == "amg":
        if load_optional("pyamg") is None:
            raise ImportError("preconditioner='amg' needs the package pyamg")
        return True
    return False


def _q_operator(system):
    """``Q`` applied as ``K M^{-1} K + mu K + lam S^T S``, never assembled: two products
    with ``K`` cost less than one with ``Q`` (2-ring stencil), and the sparse product
    ``K M^{-1} K`` is never formed.
    """
    K, mass, S, lam, mu, _rhs = system
    minv = 1.0 / mass
    St, Kmul = S.T.tocsr(), ThreadedMatvec(K)

    def qmul(x):
        Kx = Kmul(x)
        return Kmul(minv * Kx) + mu * Kx + lam * (St @ (S @ x))

    n = K.shape[0]
    return spla.LinearOperator((n, n), matvec=qmul, dtype=np.float64)


def _iterate_on(Q, P, system, phi, iters, rtol, maxiter):
    """Conjugate gradients on from ``phi`` for a system too large to factorise, for
    ``4 maxiter`` more iterations; warns with the residual reached if that is not enough.
    Returns ``phi``, the iterations in all and the relative residual.
    """
    K, rhs = system.K, system.rhs
    phi, more, _ = cg(Q, rhs, P, rtol, 4 * maxiter, x0=phi)
    iters += more
    res = relres(Q, phi, rhs)
    if res > 10 * rtol:
        n = K.shape[0]
        warnings.warn(
            f"integration solve did not converge in {iters} iterations (relative residual "
            f"{res:.2e}, target {rtol:.0e}); {n} unknowns with {K.nnz / n:.0f} entries per "
            "row are too many to factorise instead",
            ConvergenceWarning,
            stacklevel=4,  # the caller of solve_integration
        )
    return phi, iters, res


# ----------------------------------------------------------------------------- first order


def solve_gradient_integration(K, S, lam, rhs, *, rtol=1e-10, maxiter=1000, method="auto", backend="auto", cache=None):
    """Solve ``(K + lam S^T S) phi = rhs``: the normal equations of the first-order fit
    ``||grad phi - X||_A^2 + lam ||S phi - s||^2``.

    Its condition number is that of a screened Laplacian, not of its square, so
    conjugate gradients with a diagonal preconditioner converge (in 26 iterations on the
    neighbour graph of 3 000 samples, 157 on that of 20 000 samples of intrinsic
    dimension 11, at rtol 1e-6) where the squared system needs a factor or a multigrid
    cycle to converge at all.

    Parameters
    ----------
    K : sparse matrix of shape (n, n)
        Stiffness matrix, symmetric positive semidefinite.
    S : sparse matrix of shape (m, n)
        Constraint rows, weighted by ``lam``.
    lam : float
        Positive; every connected component of ``K`` needs a constraint row.
    rhs : ndarray of shape (n,)
    rtol : float, default=1e-10
        Relative residual to reach.
    maxiter : int, default=1000
        Iterations allowed to conjugate gradients before a factorisation takes over
        (``method="auto"``, up to :data:`DIRECT_FALLBACK_MAX` unknowns) or a warning.
    method : {"auto", "pcg", "direct"}, default="auto"
        ``"direct"``: a Cholesky factor of the matrix. ``"pcg"``: conjugate gradients,
        preconditioned by the inverse diagonal on neighbour graphs (rows of more than
        :data:`~ndboundary.solvers.amg.AMG_DENSE_ROWS` entries: there aggregation
        collapses to a level or two) and by one AMG V-cycle on meshes (the inverse
        diagonal without pyamg). ``"auto"``: direct on sparse rows or small systems
        (as :func:`solve_integration`), pcg elsewhere.
    backend : str, default="auto"
        Sparse Cholesky of the direct solve (:func:`~ndboundary.solvers.factorize_spd`).
    cache : FactorCache, optional
        Where to keep the factor or the AMG hierarchy for the next solve of the same matrix.

    Returns
    -------
    phi : ndarray of shape (n,)
    info : SolveInfo
        ``method`` is ``"cholesky"``, ``"pcg-jacobi"`` or ``"pcg-amg"``.

    Examples
    --------
    The gradient field of ``f(x) = x`` on a path of five vertices, held at ``f(0) = 0``:

    >>> import numpy as np, scipy.sparse as sp
    >>> G = sp.diags([-np.ones(4), np.ones(4)], [0, 1], shape=(4, 5))  # one edge a row
    >>> K = (G.T @ G).tocsr()
    >>> S = sp.csr_matrix(([1.0], ([0], [0])), shape=(1, 5))
    >>> rhs = G.T @ np.ones(4)  # the divergence of the unit field
    >>> phi, info = solve_gradient_integration(K, S, 1.0, rhs, method="direct")
    >>> (phi.round(8) + 0.0).tolist(), info.method
    ([0.0, 1.0, 2.0, 3.0, 4.0], 'cholesky')
    """
    if method not in ("auto", "pcg", "direct"):
        raise ValueError(f"method must be 'auto', 'pcg' or 'direct', got {method!r}")
    K, S = sp.csr_matrix(K), sp.csr_matrix(S)
    rhs = np.asarray(rhs, dtype=np.float64)
    t0 = time.perf_counter()
    n = K.shape[0]

    def assembled():
        return (K + lam * (S.T @ S)).tocsr()

    if method == "direct" or (method == "auto" and _is_sparse_rows(K)):
        phi, info = _factor_solve(assembled(), rhs, backend, cache)
        info.setup_time = time.perf_counter() - t0 - info.solve_time  # with the assembly
        return phi, info
    if K.nnz / max(n, 1) <= AMG_DENSE_ROWS and load_optional("pyamg") is not None:
        name = "pcg-amg"
        A = assembled()
        with one_blas_thread():
            P = spla.LinearOperator((n, n), matvec=cached("amg", A, amg_preconditioner, cache), dtype=np.float64)
    else:
        # neighbour graphs: K x + lam S^T (S x), the sum never formed (hundreds of entries
        # a row: forming it cost as much as a tenth of the iterations)
        name = "pcg-jacobi"
        St, Kx = S.T.tocsr(), ThreadedMatvec(K)
        A = spla.LinearOperator((n, n), matvec=lambda x: Kx(x) + lam * (St @ (S @ x)), dtype=np.float64)
        diag = K.diagonal() + lam * np.asarray(S.multiply(S).sum(axis=0)).ravel()
        P = sp.diags(1.0 / np.where(diag > 0, diag, 1.0))  # an empty row (no stencil, no pin) stays as it is
    t1 = time.perf_counter()
    phi, iters, flag = cg(A, rhs, P, rtol, maxiter)
    res = relres(A, phi, rhs)
    t2 = time.perf_counter()
    if flag != 0 and res > 10 * rtol:
        if method == "auto" and n <= DIRECT_FALLBACK_MAX:
            phi, info = _factor_solve(assembled(), rhs, backend, cache, iters)
            info.setup_time += t2 - t0
            return phi, info
        warnings.warn(
            f"integration solve did not converge in {iters} iterations "
            f"(relative residual {res:.2e}, target {rtol:.0e})",
            ConvergenceWarning,
            stacklevel=2,
        )
    return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)


# ----------------------------------------------------------------------------- helpers


def _is_sparse_rows(K):
    n = K.shape[0]
    return n <= SMALL_SYSTEM or K.nnz / max(n, 1) <= DENSE_ROW_THRESHOLD
