"""Operators shared by polygon and polyhedral meshes.

The consistent stiffness of cells that are not simplices (Green-Gauss ``G^T A G`` plus
the virtual-element stabilisation of its hourglass modes), the paper's combinatorial
Laplacian, and the interpolation from a mesh's vertices to its simplicial refinement.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .._compiled_mesh import assemble_cell_blocks
from .._validation import check_positive

__all__ = ["check_laplacian_options", "combinatorial_laplacian", "local_stiffness", "refinement_matrix"]

LAPLACIANS = ("consistent", "combinatorial")


def local_stiffness(points, pair_elem, pair_vertex, pair_grad, measures, stabilization, n_vertices):
    """Assemble ``sum_e A_e G_e^T G_e + s_e (I - P_e)^T (I - P_e)`` (see :mod:`ndboundary.domains.polygon`).

    Parameters
    ----------
    points : ndarray of shape (n_vertices, dim)
    pair_elem, pair_vertex : ndarray of int of shape (n_pairs,)
        The (element, vertex) incidences, sorted by element, each element's run contiguous.
    pair_grad : ndarray of shape (n_pairs, dim)
        Gradient coefficient of each vertex in its element.
    measures : ndarray of shape (n_elements,)
    stabilization : float
    n_vertices : int

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n_vertices, n_vertices)
        Exactly symmetric: each cell adds the symmetric part of its matrix. Cells of one
        shape share one matrix (:func:`_cell_stiffness_shared`), assembled by a compiled
        pass (:func:`~ndboundary._compiled_mesh.assemble_cell_blocks`) without a table of
        every cell's entries.

    Examples
    --------
    The unit square, with the gradient coefficient of each corner (``sum_i g_i f_i`` is
    the gradient of ``f``); the stiffness vanishes on constants:

    >>> import numpy as np
    >>> from ndboundary.domains.cell_operators import local_stiffness
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> coef = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    >>> K = local_stiffness(square, np.zeros(4, dtype=int), np.arange(4), coef, np.array([1.0]), 0.0, 4)
    >>> K.toarray()[0].tolist(), bool(np.allclose(K @ np.ones(4), 0.0))
    ([0.5, 0.0, -0.5, 0.0], True)
    """
    n_el = measures.size
    sizes = np.bincount(pair_elem, minlength=n_el)
    starts = np.zeros(n_el + 1, dtype=np.int64)
    np.cumsum(sizes, out=starts[1:])
    blocks, block_ptr, offset = [], np.zeros(n_el, dtype=np.int64), 0
    for m in np.flatnonzero(np.bincount(sizes)):
        els = np.flatnonzero(sizes == m)
        idx = starts[els][:, None] + np.arange(m)[None, :]  # (n, m)
        Ge = pair_grad[idx]  # (n, m, dim)
        X = points[pair_vertex[idx]]
        Ke, which = _cell_stiffness_shared(Ge, measures[els], X - X.mean(axis=1, keepdims=True), stabilization)
        blocks.append(Ke.ravel())
        block_ptr[els] = offset + which * (m * m)
        offset += Ke.size
    if not blocks:
        return sp.csr_matrix((n_vertices, n_vertices))
    return assemble_cell_blocks(starts, pair_vertex, np.concatenate(blocks), block_ptr, n_vertices)


def _cell_stiffness(Ge, A, Xc, stabilization):
    """Every cell's ``A G^T G + s (I - P)^T (I - P)``, shape (n, m, m)."""
    m = Ge.shape[1]
    Kc = A[:, None, None] * (Ge @ Ge.transpose(0, 2, 1))  # (n, m, m)
    if stabilization <= 0:
        return Kc
    P = 1.0 / m + Xc @ Ge.transpose(0, 2, 1)  # (n, m, m): P[i, j] = 1/m + xc_i . g_j
    Q = np.eye(m)[None] - P
    s = stabilization * np.einsum("nii->n", Kc) / m
    return Kc + s[:, None, None] * (Q.transpose(0, 2, 1) @ Q)


def _cell_stiffness_shared(Ge, A, Xc, stabilization):
    """:func:`_cell_stiffness`, computed once per shape where many cells share one:
    ``(blocks, which)``, cell ``i``'s matrix being ``blocks[which[i]]``.

    Cells of the same shape (the voxels of an image, the cells of a regular grid) have
    the same gradient coefficients and measure, and the same vertex offsets from their
    mean up to rounding: their matrix is computed for one of them, and stored once. A
    cell whose offsets differ from its representative's by more than ``1e-9`` of its
    size gets a block of its own.
    """
    n = Ge.shape[0]
    if n < 64:
        return _cell_stiffness(Ge, A, Xc, stabilization), np.arange(n)
    key = np.ascontiguousarray(np.concatenate([Ge.reshape(n, -1), A[:, None]], axis=1))
    if (key == key[0]).all():  # one shape only (a voxel grid): no need to sort the keys
        first, which = np.zeros(1, dtype=np.intp), np.zeros(n, dtype=np.intp)
    else:
        rows = key.view(np.dtype((np.void, key.dtype.itemsize * key.shape[1]))).ravel()
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
        if 4 * first.size > n:
            return _cell_stiffness(Ge, A, Xc, stabilization), np.arange(n)
        which = inverse.ravel()
    size = np.abs(Xc).max(axis=(1, 2))
    reference = Xc[first[0]] if first.size == 1 else Xc[first][which]  # each cell's representative
    own = np.flatnonzero(np.abs(Xc - reference).max(axis=(1, 2)) > 1e-9 * size)
    Ke = _cell_stiffness(Ge[first], A[first], Xc[first], stabilization)
    if own.size:
        which[own] = first.size + np.arange(own.size)
        Ke = np.concatenate([Ke, _cell_stiffness(Ge[own], A[own], Xc[own], stabilization)])
    return Ke, which


def combinatorial_laplacian(edges, n_vertices, scale):
    """Uniform graph Laplacian ``scale * (D - W)`` over the given edges (weight 1 each).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.cell_operators import combinatorial_laplacian
    >>> combinatorial_laplacian(np.array([[0, 1], [1, 2]]), 3, 1.0).toarray().tolist()  # a path
    [[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]
    """
    i, j = edges[:, 0], edges[:, 1]
    W = sp.coo_matrix((np.ones(i.size), (i, j)), shape=(n_vertices, n_vertices))
    W = (W + W.T).tocsr()
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr() * scale


def check_laplacian_options(laplacian, stabilization):
    """Validate the stiffness options of a polygon or polyhedral mesh; returns the weight.

    Examples
    --------
    >>> from ndboundary.domains.cell_operators import check_laplacian_options
    >>> check_laplacian_options("consistent", 1.0)
    1.0
    >>> check_laplacian_options("cotan", 1.0)
    Traceback (most recent call last):
    ...
    ValueError: laplacian must be 'consistent' or 'combinatorial', got 'cotan'
    """
    if laplacian not in LAPLACIANS:
        raise ValueError(f"laplacian must be 'consistent' or 'combinatorial', got {laplacian!r}")
    return check_positive(stabilization, "stabilization", allow_zero=True)


def refinement_matrix(n_vertices, indices, offsets):
    """Sparse (n_vertices + n_rows, n_vertices): identity, then one averaging row per ragged row.

    Examples
    --------
    One quad refined at its centre: the added vertex is the mean of the four.

    >>> import numpy as np
    >>> from ndboundary.domains.cell_operators import refinement_matrix
    >>> R = refinement_matrix(4, np.array([0, 1, 2, 3]), np.array([0, 4]))
    >>> R.shape, R.toarray()[4].tolist()
    ((5, 4), [0.25, 0.25, 0.25, 0.25])
    """
    sizes = np.diff(offsets)
    owner = np.repeat(np.arange(sizes.size), sizes)
    avg = sp.csr_matrix((1.0 / sizes[owner], (owner, indices)), shape=(sizes.size, n_vertices))
    return sp.vstack([sp.identity(n_vertices, format="csr"), avg]).tocsr()
