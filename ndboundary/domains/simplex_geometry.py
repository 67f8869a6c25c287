"""Geometry of simplices of any dimension: barycentric gradients, volumes, stiffness terms.

With ``E = [x1-x0, ..., xk-x0]`` (dim x k) the barycentric gradients are the columns of
``E (E^T E)^{-1}``, exact for linear functions and intrinsic to the simplex (valid for
surfaces in 3-D), and the volume is ``sqrt(det(E^T E)) / k!``. Up to three dimensions
the Gram matrices are inverted by cofactors, beyond by LU; both run over blocks of
simplices small enough for the temporaries to stay in cache.
"""

from __future__ import annotations

from math import comb, factorial

import numpy as np
import scipy.sparse as sp

from .._arrays import DEGENERATE_RTOL, counting_sort, index_dtype, pair_groups

__all__ = [
    "COMPILED_MIN_SIMPLICES",
    "COMPILED_MIN_VERTICES_PER_SIMPLEX",
    "aspect_ratios",
    "compiled_passes",
    "kuhn_grid_stiffness",
    "simplex_edges",
    "simplex_geometry",
    "simplex_incidence",
    "stiffness_terms",
    "symmetric_csr",
    "symmetric_inverse",
]

#: Simplices of at least this many vertices (tetrahedra and up: 6 vertex pairs each) get
#: their edges and incidence from compiled counting passes; triangles keep numpy's, as
#: fast for them without loading the compiled code in every process, up to
#: :data:`COMPILED_MIN_SIMPLICES`.
COMPILED_MIN_VERTICES_PER_SIMPLEX = 4
#: From this many simplices the incidence, the mean edge length and the edge graph come
#: from the compiled passes whatever the simplices: their sorts of every vertex pair then
#: cost more than loading the compiled code.
COMPILED_MIN_SIMPLICES = 200_000


def compiled_passes(simplices):
    """Whether the incidence and the edge graph of ``simplices`` come from compiled passes.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.simplex_geometry import compiled_passes
    >>> compiled_passes(np.zeros((10, 3), dtype=int)), compiled_passes(np.zeros((10, 4), dtype=int))
    (False, True)
    """
    return simplices.shape[1] >= COMPILED_MIN_VERTICES_PER_SIMPLEX or simplices.shape[0] >= COMPILED_MIN_SIMPLICES


# Entries of the per-block temporaries of the geometry (simplices x vertices x dim).
_BLOCK = 1 << 16


def symmetric_inverse(gram, k):
    """Determinants and cofactors of symmetric k x k matrices, k <= 3.

    ``gram[i][j]`` holds entry (i, j) of every matrix, as arrays of one shape; returns
    ``(det, cof)`` with ``cof[i, j]`` (``i <= j``) likewise: the inverse is ``cof / det``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.simplex_geometry import symmetric_inverse
    >>> det, cof = symmetric_inverse([[np.array(2.0), np.array(1.0)], [np.array(1.0), np.array(3.0)]], 2)
    >>> float(det), {ij: float(c) for ij, c in cof.items()}  # inverse of [[2, 1], [1, 3]] times 5
    (5.0, {(0, 0): 3.0, (0, 1): -1.0, (1, 1): 2.0})
    """
    g = gram
    if k == 1:
        det = g[0][0]
        cof = {(0, 0): np.ones_like(det)}
    elif k == 2:
        det = g[0][0] * g[1][1] - g[0][1] * g[0][1]
        cof = {(0, 0): g[1][1], (0, 1): -g[0][1], (1, 1): g[0][0]}
    else:
        cof = {
            (0, 0): g[1][1] * g[2][2] - g[1][2] * g[1][2],
            (0, 1): g[0][2] * g[1][2] - g[0][1] * g[2][2],
            (0, 2): g[0][1] * g[1][2] - g[0][2] * g[1][1],
            (1, 1): g[0][0] * g[2][2] - g[0][2] * g[0][2],
            (1, 2): g[0][1] * g[0][2] - g[0][0] * g[1][2],
            (2, 2): g[0][0] * g[1][1] - g[0][1] * g[0][1],
        }
        det = g[0][0] * cof[0, 0] + g[0][1] * cof[0, 1] + g[0][2] * cof[0, 2]
    return det, cof


def simplex_geometry(points, simplices):
    """Barycentric gradients and volumes of simplices.

    Returns ``(grads, vol)``: ``grads[e, :, a]`` (shape (E, dim, k+1), the layout of the
    rows of the gradient operator) is the gradient of the barycentric coordinate of
    vertex ``simplices[e, a]`` over simplex ``e``, ``vol`` the volumes (E,). Degenerate
    simplices (volume below a relative tolerance) get volume NaN and zero gradients, for
    the caller to report. Simplices are taken in blocks small enough for the
    temporaries to stay in cache.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.simplex_geometry import simplex_geometry
    >>> grads, vol = simplex_geometry(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]]))
    >>> grads[0].tolist(), vol.tolist()  # columns: the gradients of the three hat functions
    ([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]], [0.5])
    """
    E, k1 = simplices.shape
    dim = points.shape[1]
    grads = np.empty((E, dim, k1))
    vol = np.empty(E)
    block = max(64, _BLOCK // (k1 * dim))
    if k1 <= 4:
        coords = np.ascontiguousarray(points.T)
        for start in range(0, E, block):
            b = slice(start, start + block)
            vol[b] = small_simplex_geometry(coords, simplices[b], grads[b])
    else:
        for start in range(0, E, block):
            b = slice(start, start + block)
            vol[b] = large_simplex_geometry(points, simplices[b], grads[b])
    return grads, vol


def small_simplex_geometry(coords, simplices, grads):
    """:func:`simplex_geometry` of simplices of at most 3 dimensions, by cofactors.

    ``coords`` is the (dim, n_vertices) array of coordinates; the gradients are written
    to ``grads`` (n, dim, k+1) and the volumes returned.
    """
    k = simplices.shape[1] - 1
    x0 = coords[:, simplices[:, 0]]
    e = [coords[:, simplices[:, i + 1]] - x0 for i in range(k)]  # edge vectors from x0, (dim, n)
    gram = [[None] * k for _ in range(k)]
    for i in range(k):
        for j in range(i, k):
            gram[i][j] = gram[j][i] = np.einsum("dn,dn->n", e[i], e[j])
    scale = sum(gram[i][i] for i in range(k)) / k  # mean squared edge length from x0
    det, cof = symmetric_inverse(gram, k)
    bad = ~(det > (DEGENERATE_RTOL * scale) ** k)
    inv_det = 1.0 / np.where(bad, 1.0, det)
    total = 0.0
    for i in range(k):
        # gradient of the barycentric coordinate i + 1: row i of gram^{-1} times the edges
        row = sum(e[j] * (cof[min(i, j), max(i, j)] * inv_det) for j in range(k))
        grads[:, :, i + 1] = row.T
        total = total + row
    grads[:, :, 0] = -total.T
    grads[bad] = 0.0
    vol = np.sqrt(np.where(bad, 1.0, det)) / factorial(k)
    vol[bad] = np.nan
    return vol


def large_simplex_geometry(points, simplices, grads):
    """:func:`simplex_geometry` by LU factorisations of the Gram matrices; the
    gradients are written to ``grads`` (n, dim, k+1) and the volumes returned.
    """
    X = points[simplices]
    Ed = X[:, 1:, :] - X[:, :1, :]  # (n, k, dim)
    gram = Ed @ Ed.transpose(0, 2, 1)  # (n, k, k)
    k = Ed.shape[1]
    det = np.linalg.det(gram)
    scale = np.einsum("eij,eij->e", Ed, Ed) / k  # mean squared edge length from x0
    bad = ~(det > (DEGENERATE_RTOL * scale) ** k)
    gram[bad] = np.eye(k)
    vol = np.sqrt(np.where(bad, 1.0, det)) / factorial(k)
    vol[bad] = np.nan
    rest = np.linalg.inv(gram) @ Ed  # (n, k, dim): row i is grad of barycentric coordinate i+1
    rest[bad] = 0.0
    grads[:, :, 1:] = rest.transpose(0, 2, 1)
    grads[:, :, 0] = -rest.sum(axis=1)
    return vol


def stiffness_terms(grads, vol):
    """Per simplex, the entries ``vol g_i . g_j`` of ``G^T diag(A) G`` over its vertices.

    Parameters
    ----------
    grads : ndarray of shape (n, dim, k + 1)
        Barycentric gradients, as :func:`simplex_geometry` returns them.
    vol : ndarray of shape (n,)

    Returns
    -------
    off : ndarray of shape (n, k (k + 1) / 2)
        The vertex pairs ``i < j`` in ``triu_indices`` order.
    diag : ndarray of shape (n, k + 1)

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.simplex_geometry import simplex_geometry, stiffness_terms
    >>> grads, vol = simplex_geometry(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]]))
    >>> off, diag = stiffness_terms(grads, vol)
    >>> off.tolist(), diag.tolist()  # pairs (0, 1), (0, 2), (1, 2)
    ([[-0.5, -0.5, 0.0]], [[1.0, 0.5, 0.5]])
    """
    n, _, k1 = grads.shape
    if k1 >= COMPILED_MIN_VERTICES_PER_SIMPLEX:
        from .._compiled_geometry import stiffness_terms_compiled

        return stiffness_terms_compiled(grads, vol)
    iu, ju = np.triu_indices(k1, 1)
    off = np.empty((n, iu.size))
    for p, (i, j) in enumerate(zip(iu, ju, strict=True)):
        off[:, p] = np.einsum("ed,ed->e", grads[:, :, i], grads[:, :, j]) * vol
    diag = np.empty((n, k1))
    for i in range(k1):
        diag[:, i] = np.einsum("ed,ed->e", grads[:, :, i], grads[:, :, i]) * vol
    return off, diag


def symmetric_csr(edges, off, diag, has_diag):
    """The symmetric sparse matrix with entries ``off`` at the ``edges`` and at their
    transposes and ``diag`` on the diagonal where ``has_diag``, in canonical CSR form.

    ``edges`` are distinct pairs ``i < j`` in lexicographic order (the row-major order of
    the upper triangle); the lower triangle is their counting sort by ``j``.

    Examples
    --------
    The stiffness matrix of one right triangle, from its :func:`stiffness_terms`:

    >>> import numpy as np
    >>> from ndboundary.domains.simplex_geometry import symmetric_csr
    >>> edges = np.array([[0, 1], [0, 2], [1, 2]])
    >>> K = symmetric_csr(edges, np.array([-0.5, -0.5, 0.0]), np.array([1.0, 0.5, 0.5]), np.ones(3, dtype=bool))
    >>> K.toarray().tolist(), bool(K.has_canonical_format)
    ([[1.0, -0.5, -0.5], [-0.5, 0.5, 0.0], [-0.5, 0.0, 0.5]], True)
    """
    n = diag.size
    i, j = edges[:, 0], edges[:, 1]
    n_edges = i.size
    idx = index_dtype(2 * n_edges + n)
    lower, lower_start = counting_sort(j, n)  # (j, i) in row-major order
    n_lower = np.diff(lower_start)
    n_upper = np.bincount(i, minlength=n)
    indptr = np.zeros(n + 1, dtype=idx)
    np.cumsum(n_lower + has_diag + n_upper, out=indptr[1:])
    indices = np.empty(int(indptr[-1]), dtype=idx)
    data = np.empty(int(indptr[-1]))
    rank = np.arange(n_edges)
    # per row: the lower triangle, the diagonal, the upper triangle
    pos = rank + (indptr[:-1] - lower_start[:-1])[j[lower]]
    indices[pos] = i[lower]
    data[pos] = off[lower]
    rows = np.flatnonzero(has_diag)
    pos = indptr[rows] + n_lower[rows]
    indices[pos] = rows
    data[pos] = diag[rows]
    upper_start = np.cumsum(n_upper) - n_upper
    pos = rank + (indptr[:-1] + n_lower + has_diag - upper_start)[i]
    indices[pos] = j
    data[pos] = off
    return sp.csr_matrix((data, indices, indptr), shape=(n, n))


def aspect_ratios(points, simplices, volumes):
    """``L^k / (k! V)`` per simplex, ``L`` its longest edge and ``V`` its volume, divided
    by the regular simplex's value (1 for a regular simplex).

    Examples
    --------
    >>> import numpy as np
    >>> tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> round(float(aspect_ratios(tri, np.array([[0, 1, 2]]), np.array([np.sqrt(3) / 4]))[0]), 12)
    1.0
    """
    k = simplices.shape[1] - 1
    if simplices.shape[1] >= COMPILED_MIN_VERTICES_PER_SIMPLEX:
        from .._compiled_geometry import longest_edges

        longest = longest_edges(points, simplices)
    else:
        squared = np.zeros(simplices.shape[0])
        for i, j in zip(*np.triu_indices(k + 1, 1), strict=True):
            d = points[simplices[:, i]] - points[simplices[:, j]]
            np.maximum(squared, np.einsum("ij,ij->i", d, d), out=squared)
        longest = np.sqrt(squared)
    return longest**k * np.sqrt(k + 1) / (2 ** (k / 2) * factorial(k) * volumes)


def simplex_edges(srt, n_vertices):
    """The unique edges of simplices with sorted rows ``srt``, sorted, and the edge of every
    vertex pair ``(srt[e, i], srt[e, j])``, ``i < j`` in ``triu_indices`` order, element-major.

    Examples
    --------
    >>> import numpy as np
    >>> edges, pair_edge = simplex_edges(np.array([[0, 1, 2], [1, 2, 3]]), 4)
    >>> edges.tolist(), pair_edge.tolist()
    ([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [0, 1, 2, 2, 3, 4])
    """
    V = n_vertices
    E, k1 = srt.shape
    iu, ju = np.triu_indices(k1, 1)
    idx = index_dtype(max(V, E * iu.size))
    s = srt.astype(idx, copy=False)
    first, second = np.take(s, iu, axis=1).ravel(), np.take(s, ju, axis=1).ravel()
    if k1 >= COMPILED_MIN_VERTICES_PER_SIMPLEX:
        from .._compiled import unique_pairs

        edges, pair_edge = unique_pairs(first, second, V)
        return edges.astype(srt.dtype, copy=False), pair_edge
    order, new = pair_groups(first, second, V)
    pair_edge = np.empty(first.size, dtype=np.intp)
    pair_edge[order] = np.cumsum(new, dtype=np.intp) - 1
    head = order[new]
    edges = np.empty((head.size, 2), dtype=srt.dtype)
    edges[:, 0] = first[head]
    edges[:, 1] = second[head]
    return edges, pair_edge


def simplex_incidence(simplices, sorted_simplices, n_vertices, dtype=np.float64):
    """The vertex-element incidence (n_vertices, n_elements) of simplices, ones (of
    ``dtype``) where a vertex belongs to an element.

    Examples
    --------
    >>> import numpy as np
    >>> simplex_incidence(np.array([[0, 1, 2], [2, 1, 3]]), np.array([[0, 1, 2], [1, 2, 3]]), 4).toarray().tolist()
    [[1.0, 0.0], [1.0, 1.0], [1.0, 1.0], [0.0, 1.0]]
    """
    E, k1 = simplices.shape
    idx = index_dtype(max(E * k1, n_vertices))
    if not compiled_passes(simplices):
        # the element-vertex matrix, one row per simplex, transposed
        by_element = sp.csr_matrix(
            (np.ones(E * k1, dtype=dtype), sorted_simplices.astype(idx).ravel(), np.arange(E + 1, dtype=idx) * k1),
            shape=(E, n_vertices),
        )
        return by_element.T.tocsr()
    from .._compiled import rows_by_value

    indptr, indices = rows_by_value(simplices, n_vertices, idx)  # a counting pass
    return sp.csr_matrix((np.ones(E * k1, dtype=dtype), indices, indptr), shape=(n_vertices, E))


def kuhn_grid_stiffness(k):
    """``diag(K M^{-1} K)`` at an interior vertex of the regular Kuhn grid of dimension ``k``,
    lengths in units of its mean edge length.

    On that grid, in units of the cell size, ``K`` is the ``2k + 1``-point Laplacian stencil
    and ``M = 1`` at interior vertices, so the diagonal is ``(2k)^2 + 2k``; the grid's edges
    join a vertex to its ``2^k - 1`` neighbours ``x + sum_{i in I} e_i``, of length
    ``sqrt(|I|)``, and the diagonal scales as ``length^{k-4}``.

    Examples
    --------
    >>> from ndboundary.domains import kuhn_grid_stiffness
    >>> round(kuhn_grid_stiffness(1), 6)
    6.0
    """
    sizes = np.arange(1, k + 1)
    mean_edge = float(np.sum([comb(k, j) * np.sqrt(j) for j in sizes])) / (2**k - 1)
    return (4 * k * k + 2 * k) * mean_edge ** (4 - k)
