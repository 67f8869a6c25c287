"""The heat system ``(M + t K) u = b`` with ``t = h^2``: :func:`solve_heat`.

It is mass dominated: its conditioning does not grow with the mesh, so
Jacobi-preconditioned conjugate gradients converge in a few dozen iterations at any
size, and no factorisation is needed.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._compiled import ThreadedMatvec
from .cholesky import factorize_spd
from .common import SolveInfo, cg, one_blas_thread, relres, warn_unconverged

__all__ = ["solve_heat"]


def solve_heat(mass, K, t, b, *, rtol=1e-10, maxiter=2000):
    """Solve ``(diag(mass) + t K) u = b`` by Jacobi-preconditioned conjugate gradients.

    Should the iteration stop short of ``rtol`` (by more than a factor 10, measured on the
    true residual), a sparse Cholesky factorisation
    (:func:`~ndboundary.solvers.factorize_spd`) solves the system instead; should that
    miss it too (elements so thin that the system is numerically singular), a
    :class:`~ndboundary.solvers.ConvergenceWarning` names the residual reached.

    Parameters
    ----------
    mass : ndarray of shape (n,)
        Diagonal of the (lumped) mass matrix ``M``.
    K : sparse matrix of shape (n, n)
        Stiffness matrix, symmetric positive semidefinite.
    t : float
        Time of the heat flow (one backward Euler step; the relaxation uses ``h^2``,
        ``h`` the mean edge length).
    b : ndarray of shape (n,)
        Right-hand side.
    rtol : float, default=1e-10
        Relative residual to reach: tight enough that the solve's error is negligible
        next to the discretisation's, which costs little on this well-conditioned
        system.
    maxiter : int, default=2000
        Iterations allowed before the factorisation takes over; far more than the few
        dozen a mass-dominated system needs, so that it is only a safeguard.

    Returns
    -------
    u : ndarray of shape (n,)
    info : SolveInfo
        ``method`` is ``"cg-jacobi"``, or ``"cholesky"`` after the fallback.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> K = sp.csr_matrix([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> mass = np.array([0.5, 1.0, 0.5])
    >>> b = np.array([1.0, 0.0, 0.0])
    >>> u, info = solve_heat(mass, K, 0.1, b)
    >>> bool(np.allclose((sp.diags(mass) + 0.1 * K) @ u, b)), info.method
    (True, 'cg-jacobi')
    """
    t0 = time.perf_counter()
    K = sp.csr_matrix(K)
    mass = np.asarray(mass, dtype=np.float64)
    # M + t K applied as mass x + t (K x): the sum of the two matrices is never formed
    # (on a neighbour graph's stiffness, hundreds of entries a row, forming it cost as
    # much as a tenth of the iterations)
    Kx = ThreadedMatvec(K)
    A = spla.LinearOperator(K.shape, matvec=lambda x: mass * x + t * Kx(x), dtype=np.float64)
    dinv = 1.0 / (mass + t * K.diagonal())
    P = spla.LinearOperator(K.shape, matvec=lambda r: dinv * r, dtype=np.float64)
    t1 = time.perf_counter()
    u, iters, _ = cg(A, b, P, rtol, maxiter)
    result = SolveInfo("cg-jacobi", iters, relres(A, u, b), t1 - t0, 0.0)
    if not result.residual <= 10 * rtol:
        with one_blas_thread():
            direct = factorize_spd((sp.diags(mass) + t * K).tocsc())(b)
        residual = relres(A, direct, b)
        if np.isfinite(direct).all() and residual < result.residual:
            u, result = direct, SolveInfo("cholesky", iters, residual, t1 - t0, 0.0)
    result.solve_time = time.perf_counter() - t1
    if not result.residual <= 10 * rtol:
        warn_unconverged("heat (step 1)", result, rtol, stacklevel=3)
    return u, result
