"""The levels of the smoothed-aggregation AMG on meshes, built by compiled passes
(numba): :func:`energy_hierarchy`.

With ``theta = 0`` they are pyamg's levels for the settings of
:func:`~ndboundary.solvers.amg.amg_preconditioner` on meshes (energy-minimised
prolongators): the same aggregates, the same prolongators and coarse operators up to
rounding. A positive ``theta`` aggregates over the strong couplings only
(:func:`strong_pattern`), as pyamg's standard aggregation of that pattern would.

pyamg builds the levels in BSR format with 1x1 blocks and new sparse matrices at every
step of the energy minimisation; these passes update the prolongator in place on its
sparsity pattern and form each coarse operator without the intermediate product, in
about a third of pyamg's time on tetrahedral band systems.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import scipy.sparse as sp

from .._compiled import sort_short
from .._kernels import kernel

__all__ = ["ENERGY_TOL", "Level", "energy_hierarchy", "strong_pattern"]

#: An energy minimisation stops early at this squared preconditioned residual (pyamg's default).
ENERGY_TOL = 1e-8


class Level(NamedTuple):
    """A level: its operator ``A``; the prolongator ``P`` from the next level, ``R = P^T``
    and each row's aggregate (-1: none), None on the coarsest.
    """

    A: sp.csr_matrix
    P: sp.csr_matrix | None
    R: sp.csr_matrix | None
    aggregates: np.ndarray | None


@kernel("Tuple((i8[::1], i8))(u4[::1], u4[::1])")
@numba.njit(cache=True, nogil=True)
def _aggregate(indptr, indices):  # pragma: no cover - compiled
    """The standard aggregation of pyamg (its C++ kernel, pass for pass) of the matrix's
    graph: the aggregate of each row (-1: isolated) and their number. A row none of whose
    neighbours is aggregated starts an aggregate with them; a row left over joins the
    aggregate of its first aggregated neighbour, or else starts one with its
    unaggregated neighbours (who join the aggregate before, as pyamg numbers them).
    """
    n = indptr.size - 1
    x = np.zeros(n, np.int64)
    count = 1
    for i in range(n):
        if x[i] != 0:
            continue
        neighbours = taken = False
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j != i:
                neighbours = True
                if x[j] != 0:
                    taken = True
                    break
        if not neighbours:
            x[i] = -n
        elif not taken:
            x[i] = count
            for k in range(indptr[i], indptr[i + 1]):
                x[indices[k]] = count
            count += 1
    for i in range(n):
        if x[i] != 0:
            continue
        for k in range(indptr[i], indptr[i + 1]):
            xj = x[indices[k]]
            if xj > 0:
                x[i] = -xj
                break
    count -= 1
    for i in range(n):
        xi = x[i]
        if xi != 0:
            if xi > 0:
                x[i] = xi - 1
            elif xi == -n:
                x[i] = -1
            else:
                x[i] = -xi - 1
            continue
        x[i] = count
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if x[j] == 0:
                x[j] = count
        count += 1
    return x, count


@kernel("UniTuple(u4[::1], 2)(u4[::1], u4[::1], f8[::1], i8[::1], i8)")
@numba.njit(cache=True, nogil=True)
def _pattern(indptr, indices, data, agg, count):  # pragma: no cover - compiled
    """The sparsity pattern of the smoothed prolongator, that of ``A T`` (``T`` the
    tentative prolongator): row ``i`` holds, sorted, its own aggregate and those of its
    neighbours through non-zero entries.
    """
    n = indptr.size - 1
    mark = np.full(count, -1, np.int64)
    Pp = np.zeros(n + 1, indptr.dtype)
    Pj = np.empty(indptr[n] + n, indices.dtype)  # at most a column per entry and row
    p = 0
    for i in range(n):
        start = p
        a = agg[i]
        if a >= 0:
            mark[a] = i
            Pj[p] = a
            p += 1
        for k in range(indptr[i], indptr[i + 1]):
            a = agg[indices[k]]
            if a >= 0 and mark[a] != i and data[k] != 0.0:
                mark[a] = i
                Pj[p] = a
                p += 1
        sort_short(Pj, start, p)
        Pp[i + 1] = p
    return Pp, Pj[:p].copy()


@kernel("UniTuple(f8[::1], 2)(i8[::1], f8[::1], i8)")
@numba.njit(cache=True, nogil=True)
def _tentative(agg, B, count):  # pragma: no cover - compiled
    """The tentative prolongator of pyamg for one candidate vector ``B``: ``B``
    normalised on each aggregate. Returns each row's entry (in the column of its
    aggregate) and the coarse candidate vector, the norms of ``B`` on the aggregates.
    """
    n = agg.size
    norms = np.zeros(count)
    for i in range(n):
        if agg[i] >= 0:
            norms[agg[i]] += B[i] * B[i]
    Bc = np.sqrt(norms)
    values = np.zeros(n)
    for i in range(n):
        a = agg[i]
        if a >= 0 and Bc[a] > 0.0:
            values[i] = B[i] * (1.0 / Bc[a])
    return values, Bc


@numba.njit(cache=True, nogil=True)
def _products(indptr, indices, data, Pp, Pj, X, count, out):  # pragma: no cover - compiled
    """``out = A X`` on the pattern ``(Pp, Pj)`` of ``X`` (pyamg's incomplete product):
    products outside a row's pattern go to a scratch slot, without a branch.
    """
    n = indptr.size - 1
    m = Pj.size
    acc = np.zeros(m + 1)
    slot = np.full(count, m, np.int64)
    for i in range(n):
        for q in range(Pp[i], Pp[i + 1]):
            slot[Pj[q]] = q
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            a = data[k]
            for q in range(Pp[j], Pp[j + 1]):
                acc[slot[Pj[q]]] += a * X[q]
        for q in range(Pp[i], Pp[i + 1]):
            slot[Pj[q]] = m
    for q in range(m):  # a loop: a slice assignment compiles its shape checks' messages
        out[q] = acc[q]


@numba.njit(cache=True, nogil=True)
def _tentative_products(indptr, indices, data, Pp, Pj, agg, values, count, out):  # pragma: no cover - compiled
    """:func:`_products` for the tentative prolongator, ``values[j]`` in column ``agg[j]``."""
    n = indptr.size - 1
    m = Pj.size
    acc = np.zeros(m + 1)
    slot = np.full(count + 1, m, np.int64)  # slot[count]: the rows without an aggregate
    for i in range(n):
        for q in range(Pp[i], Pp[i + 1]):
            slot[Pj[q]] = q
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            a = agg[j]
            acc[slot[a if a >= 0 else count]] += data[k] * values[j]
        for q in range(Pp[i], Pp[i + 1]):
            slot[Pj[q]] = m
    for q in range(m):  # a loop: a slice assignment compiles its shape checks' messages
        out[q] = acc[q]


@numba.njit(cache=True, nogil=True)
def _constrain(Pp, Pj, U, Bc, BtBinv):  # pragma: no cover - compiled
    """Project the rows of ``U`` on ``U Bc = 0`` (pyamg's ``satisfy_constraints``): the
    update keeps ``P Bc = B``.
    """
    n = Pp.size - 1
    for i in range(n):
        s = 0.0
        for q in range(Pp[i], Pp[i + 1]):
            s += U[q] * Bc[Pj[q]]
        s *= BtBinv[i]
        for q in range(Pp[i], Pp[i + 1]):
            U[q] -= s * Bc[Pj[q]]


@kernel("f8[::1](u4[::1], u4[::1], f8[::1], u4[::1], u4[::1], i8[::1], f8[::1], f8[::1], i8, f8)")
@numba.njit(cache=True, nogil=True)
def _energy(indptr, indices, data, Pp, Pj, agg, values, Bc, maxiter, tol):  # pragma: no cover - compiled
    """The energy minimisation of pyamg (``cg_prolongation_smoothing``, local weighting):
    ``maxiter`` iterations of conjugate gradients on ``A P = 0`` restricted to the
    pattern, from the tentative prolongator and subject to ``P Bc = B``. Returns
    ``P``'s values on the pattern.
    """
    n = indptr.size - 1
    m = Pj.size
    count = Bc.size
    Dinv = np.zeros(n)  # inverse absolute row sums of A
    BtBinv = np.zeros(n)  # inverse squared norm of Bc on each row's pattern
    for i in range(n):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += abs(data[k])
        if s != 0.0:
            Dinv[i] = 1.0 / s
        s = 0.0
        for q in range(Pp[i], Pp[i + 1]):
            s += Bc[Pj[q]] * Bc[Pj[q]]
        if s != 0.0:
            BtBinv[i] = 1.0 / s
    T = np.zeros(m)
    for i in range(n):
        for q in range(Pp[i], Pp[i + 1]):
            if Pj[q] == agg[i]:
                T[q] = values[i]
    R = np.empty(m)
    _tentative_products(indptr, indices, data, Pp, Pj, agg, values, count, R)
    for q in range(m):
        R[q] = -R[q]
    _constrain(Pp, Pj, R, Bc, BtBinv)
    Z = np.empty(m)
    D = np.zeros(m)
    AD = np.empty(m)
    oldsum = 1.0
    for it in range(maxiter):
        newsum = 0.0
        for i in range(n):
            for q in range(Pp[i], Pp[i + 1]):
                Z[q] = Dinv[i] * R[q]
                newsum += R[q] * Z[q]
        if newsum < tol:
            break
        beta = 0.0 if it == 0 else newsum / oldsum
        for q in range(m):
            D[q] = Z[q] + beta * D[q]
        oldsum = newsum
        _products(indptr, indices, data, Pp, Pj, D, count, AD)
        _constrain(Pp, Pj, AD, Bc, BtBinv)
        den = 0.0
        for q in range(m):
            den += D[q] * AD[q]
        alpha = newsum / den
        for q in range(m):
            T[q] += alpha * D[q]
            R[q] -= alpha * AD[q]
    return T


@kernel("Tuple((u4[::1], u4[::1], f8[::1]))(" + ", ".join(["u4[::1], u4[::1], f8[::1]"] * 3) + ", i8)")
@numba.njit(cache=True, nogil=True)
def _galerkin(Rp, Rj, Rx, indptr, indices, data, Pp, Pj, Px, count):  # pragma: no cover - compiled
    """The coarse operator ``(R A) P`` as scipy's two products form it in pyamg, without
    storing ``R A``: each row of ``R A`` lists its columns in the reverse order of their
    first appearance, drops exact zeros and is multiplied by ``P`` in that order, so the
    products, their sums and the order of the columns are scipy's.
    """
    n = indptr.size - 1
    link = np.full(n, -1, np.int64)  # each row's columns, linked as they appear
    acc = np.zeros(n)
    link_c = np.full(count, -1, np.int64)
    acc_c = np.zeros(count)
    Cp = np.zeros(count + 1, Rp.dtype)
    Cj = np.empty(2 * Rj.size + 16, Rj.dtype)  # grown when short
    Cx = np.empty(Cj.size)
    nnz = 0
    for c in range(count):
        head, length = -2, 0
        for p in range(Rp[c], Rp[c + 1]):
            i = Rj[p]
            v = Rx[p]
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                acc[j] += v * data[k]
                if link[j] == -1:
                    link[j] = head
                    head = j
                    length += 1
        head_c, length_c = -2, 0
        for _ in range(length):
            j = head
            v = acc[j]
            if v != 0.0:
                for q in range(Pp[j], Pp[j + 1]):
                    a = Pj[q]
                    acc_c[a] += v * Px[q]
                    if link_c[a] == -1:
                        link_c[a] = head_c
                        head_c = a
                        length_c += 1
            head = link[j]
            link[j] = -1
            acc[j] = 0.0
        if nnz + length_c > Cj.size:
            grown = max(2 * Cj.size, nnz + length_c)
            Cj = np.concatenate((Cj[:nnz], np.empty(grown - nnz, Cj.dtype)))
            Cx = np.concatenate((Cx[:nnz], np.empty(grown - nnz)))
        for _ in range(length_c):
            a = head_c
            if acc_c[a] != 0.0:
                Cj[nnz] = a
                Cx[nnz] = acc_c[a]
                nnz += 1
            head_c = link_c[a]
            link_c[a] = -1
            acc_c[a] = 0.0
        Cp[c + 1] = nnz
    return Cp, Cj[:nnz].copy(), Cx[:nnz].copy()


@kernel("UniTuple(u4[::1], 2)(u4[::1], u4[::1], f8[::1], f8)")
@numba.njit(cache=True, nogil=True)
def _strong(indptr, indices, data, theta):  # pragma: no cover - compiled
    """The rows of :func:`strong_pattern`, in two passes over ``A``'s entries."""
    n = indptr.size - 1
    largest = np.zeros(n)
    for i in range(n):
        m = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            if indices[p] != i and abs(data[p]) > m:
                m = abs(data[p])
        largest[i] = m
    out_ptr = np.zeros(n + 1, dtype=indptr.dtype)
    out_idx = np.empty(indices.size, dtype=indices.dtype)
    k = 0
    for i in range(n):
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if j == i or abs(data[p]) >= theta * min(largest[i], largest[j]):
                out_idx[k] = j
                k += 1
        out_ptr[i + 1] = k
    return out_ptr, out_idx[:k].copy()


def _unsigned(a):
    """32-bit indices as unsigned: the compiled loops skip the checks for negative ones."""
    return a.view(np.uint32) if a.dtype == np.int32 else a


def _signed(a):
    return a.view(np.int32) if a.dtype == np.uint32 else a


def strong_pattern(A, theta):
    """The strong couplings of the CSR matrix ``A``, the pattern the aggregation reads: its
    diagonal and every entry with ``|a_ij| >= theta * min(m_i, m_j)``, ``m_i`` the largest
    magnitude off the diagonal of row ``i``. ``(indptr, indices)``, rows in ``A``'s order.

    The test is symmetric (a coupling strong for either row is kept for both) and free of
    each row's scale. On a grid of stretched cells the couplings along the long side are
    weak, and Gauss-Seidel smooths the error along the short sides only: aggregates over
    the strong couplings stay across the short sides, where the coarse level can represent
    that error.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary.solvers.amg_hierarchy import strong_pattern
    >>> A = sp.csr_matrix(np.array([[4.0, -2.0, -0.01], [-2.0, 4.0, -2.0], [-0.01, -2.0, 4.0]]))
    >>> indptr, indices = strong_pattern(A, 0.1)
    >>> indptr.tolist(), indices.tolist()  # the weak 0-2 coupling is dropped
    ([0, 2, 5, 7], [0, 1, 0, 1, 2, 1, 2])
    """
    indptr, indices = _strong(_unsigned(A.indptr), _unsigned(A.indices), A.data, float(theta))
    return _signed(indptr), _signed(indices)


def energy_hierarchy(A, *, maxiter=2, max_coarse=500, max_levels=10, theta=0.0):
    """The levels of smoothed-aggregation AMG for ``A`` with energy-minimised
    prolongators: those of pyamg's ``smoothed_aggregation_solver(A, symmetry="symmetric",
    strength="symmetric", aggregate="standard", smooth=("energy", {"maxiter": maxiter}),
    improve_candidates=None, max_coarse=max_coarse, max_levels=max_levels)``.

    With ``theta > 0`` each level is aggregated over its :func:`strong_pattern` instead
    of its whole pattern (pyamg's ``strength="symmetric"`` with ``theta = 0`` keeps every
    coupling): the rest is unchanged. Coarsening goes on while a level has more than
    ``max_coarse`` rows, up to ``max_levels`` levels. Each coarse operator ``(R A) P`` is formed as scipy's sparse
    products form it in pyamg (:func:`_galerkin`), so its rows list their columns in the
    order of pyamg's: the order its aggregation reads them in.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite, with the constants close to its null space.
    maxiter : int, default=2
        Iterations of the energy minimisation of each prolongator.
    max_coarse, max_levels : int
    theta : float, default=0.0
        The strength threshold of the aggregation (:func:`strong_pattern`); 0 aggregates
        over every coupling, as pyamg's levels for these settings.

    Returns
    -------
    levels : list of Level
        Finest first, every one in CSR format.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> n = 2000  # a path graph's Laplacian plus a small diagonal
    >>> A = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) + 0.01 * sp.identity(n)
    >>> levels = energy_hierarchy(A)
    >>> [level.A.shape[0] for level in levels]  # aggregates of three vertices
    [2000, 667, 223]
    >>> P = levels[0].P
    >>> bool(np.allclose(P @ np.sqrt(np.bincount(levels[0].aggregates)), 1.0))  # P B_coarse = B
    True
    """
    A = sp.csr_matrix(A, dtype=np.float64)
    B = np.ones(A.shape[0])
    levels = []
    while A.shape[0] > max_coarse and len(levels) < max_levels - 1:
        n = A.shape[0]
        pattern = strong_pattern(A, theta) if theta > 0 else (A.indptr, A.indices)
        agg, count = _aggregate(_unsigned(pattern[0]), _unsigned(pattern[1]))
        count = max(count, 1)  # no aggregate at all: one empty column, as in pyamg
        if not A.has_canonical_format:
            # aggregated in the order of its product, the operator is then sorted, as
            # pyamg's energy minimisation sorts it in place (the caller's on a copy): the
            # product below lists the next level's columns in pyamg's order
            A = A if levels else A.copy()
            A.sum_duplicates()
        indptr, indices = _unsigned(A.indptr), _unsigned(A.indices)
        Pp, Pj = _pattern(indptr, indices, A.data, agg, count)
        values, Bc = _tentative(agg, B, count)
        Px = _energy(indptr, indices, A.data, Pp, Pj, agg, values, Bc, maxiter, ENERGY_TOL)
        P = sp.csr_matrix((Px, _signed(Pj), _signed(Pp)), shape=(n, count))
        P.eliminate_zeros()  # as pyamg's prolongator: the coarse pattern follows
        R = P.T.tocsr()
        levels.append(Level(A, P, R, agg))
        Cp, Cj, Cx = _galerkin(
            _unsigned(R.indptr), _unsigned(R.indices), R.data, indptr, indices, A.data,
            _unsigned(P.indptr), _unsigned(P.indices), P.data, count,
        )  # fmt: skip
        A, B = sp.csr_matrix((Cx, _signed(Cj), _signed(Cp)), shape=(count, count)), Bc
    levels.append(Level(A, None, None, None))
    return levels
