"""Linear solvers for the two systems of the relaxation.

* Heat, ``(M + t K) u = b`` with ``t = h^2``: mass dominated, its conditioning does
  not grow with the mesh, so Jacobi-preconditioned conjugate gradients converge in a
  few dozen iterations at any size.
* Integration, ``(K M^{-1} K + lam S^T S) phi = r`` (a squared Laplacian): conjugate
  gradients preconditioned by ``(K + eps M)^{-1} M (K + eps M)^{-1}``, one sparse
  factorisation of a Laplacian-sized matrix, with ``eps^2`` matched to the strength of
  the constraint; a direct factorisation of the whole matrix when the iteration stalls.

Every solve reports its relative residual; an iteration that does not reach its
tolerance warns with the residual it reached.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["SolveInfo", "solve_heat", "solve_integration", "factorize_spd"]


@dataclass
class SolveInfo:
    """What a solve did: its method, iteration count and the relative residual reached."""

    method: str
    iterations: int
    residual: float


def factorize_spd(A):
    """Return a function solving ``A x = b`` for a sparse symmetric positive definite ``A``.

    SuperLU in symmetric mode (minimum degree on ``A + A^T``, diagonal pivots), which
    behaves like a sparse Cholesky factorisation.
    """
    A = sp.csc_matrix(A)
    lu = spla.splu(
        A,
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve


def _relres(A, x, b):
    nb = np.linalg.norm(b)
    return float(np.linalg.norm(A @ x - b) / nb) if nb > 0 else 0.0


def _cg(A, b, M, rtol, maxiter, x0=None):
    it = [0]

    def count(_):
        it[0] += 1

    x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=maxiter, M=M, callback=count)
    return x, it[0], info


def solve_heat(mass, K, t, b, *, rtol=1e-10, maxiter=2000):
    """Solve ``(diag(mass) + t K) u = b`` by Jacobi-preconditioned conjugate gradients."""
    A = (sp.diags(mass) + t * K).tocsr()
    dinv = 1.0 / A.diagonal()
    P = spla.LinearOperator(A.shape, matvec=lambda r: dinv * r, dtype=np.float64)
    u, iters, info = _cg(A, b, P, rtol, maxiter)
    res = _relres(A, u, b)
    if info != 0 and res > 10 * rtol:
        u = factorize_spd(A)(b)
        res2 = _relres(A, u, b)
        return u, SolveInfo("cholesky", iters, res2)
    return u, SolveInfo("cg-jacobi", iters, res)


def solve_integration(K, mass, S, lam, rhs, *, mu=0.0, rtol=1e-10, maxiter=200, method="auto"):
    """Solve ``(K M^{-1} K + mu K + lam S^T S) phi = rhs``.

    Parameters
    ----------
    K : sparse matrix of shape (n, n)
    mass : ndarray of shape (n,)
    S : sparse matrix of shape (m, n)
    lam : float
    rhs : ndarray of shape (n,)
    method : {"auto", "pcg", "direct"}, default="auto"
        ``"pcg"``: conjugate gradients preconditioned with one factorisation of
        ``K + eps M``; ``"direct"``: factorise the whole matrix; ``"auto"``: pcg,
        falling back to direct when it does not converge in ``maxiter`` iterations.
    """
    Minv = sp.diags(1.0 / mass)
    Q = (K @ Minv @ K + mu * K + lam * (S.T @ S)).tocsr()
    Q = (Q + Q.T) * 0.5
    if method == "direct":
        phi = factorize_spd(Q)(rhs)
        return phi, SolveInfo("cholesky", 0, _relres(Q, phi, rhs))
    # (K + C) M^{-1} (K + C) with C M^{-1} C = lam diag(S^T S): the constraint's share
    # of Q is matched exactly on the diagonal, the squared Laplacian exactly off it.
    sts = np.asarray(abs(S).T @ abs(S) @ np.ones(S.shape[1])).ravel()
    c = np.sqrt(lam * sts * mass)
    solve = factorize_spd((K + sp.diags(c)).tocsc())

    def apply(r):
        return solve(mass * solve(r))

    P = spla.LinearOperator(Q.shape, matvec=apply, dtype=np.float64)
    phi, iters, info = _cg(Q, rhs, P, rtol, maxiter)
    res = _relres(Q, phi, rhs)
    if info != 0 and res > 10 * rtol:
        if method == "pcg":
            warnings.warn(
                f"integration solve did not converge in {iters} iterations "
                f"(relative residual {res:.2e}, target {rtol:.0e})",
                RuntimeWarning,
                stacklevel=3,
            )
            return phi, SolveInfo("pcg", iters, res)
        phi = factorize_spd(Q)(rhs)
        return phi, SolveInfo("cholesky", iters, _relres(Q, phi, rhs))
    return phi, SolveInfo("pcg", iters, res)
