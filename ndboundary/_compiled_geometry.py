"""Compiled loops (numba) for the geometry of large simplicial complexes: volumes,
barycentric gradients and longest edges, one simplex at a time.

Each runs in one pass with a few scalars of state per simplex, where the vectorised
versions allocate temporaries many times the mesh's size: on a tetrahedral mesh of a
million vertices those temporaries, not the arithmetic, set the time.
"""

from __future__ import annotations

import numba
import numpy as np

from ._kernels import kernel

__all__ = [
    "crossing_orientations",
    "crossing_pattern",
    "full_simplex_volumes",
    "longest_edges",
    "small_simplex_geometry_compiled",
    "small_simplex_volumes",
    "stiffness_terms_compiled",
]


@numba.njit(cache=True, nogil=True, inline="always")
def _tet_gradient(grads, s, d, e0, e1, e2, m00, m01, m02, m11, m12, m22):  # pragma: no cover - compiled
    """Component ``d`` of tetrahedron ``s``'s gradients from that component of its edges."""
    r = 0.0 + e0 * m00 + e1 * m01 + e2 * m02
    t = 0.0 + e0 * m01 + e1 * m11 + e2 * m12
    u = 0.0 + e0 * m02 + e1 * m12 + e2 * m22
    grads[s, d, 0] = 0.0 - r - t - u
    grads[s, d, 1] = r
    grads[s, d, 2] = t
    grads[s, d, 3] = u


@kernel("void(f8[:, ::1], i8[:, ::1], f8, f8[:, :, ::1], f8[::1], b1)")
@numba.njit(cache=True, nogil=True)
def _tet_geometry(points, simplices, rtol, grads, vol, with_gradients):  # pragma: no cover - compiled
    """:func:`_small_geometry` on tetrahedra in space: the same operations in the same
    order, so the same values to the bit, on scalars instead of small arrays, and the
    cofactors off the first row only when the gradients are asked for.
    """
    k = simplices.shape[1] - 1  # 3, typed as in the general pass
    norm = 1.0
    for i in range(2, k + 1):
        norm *= i
    for s in range(simplices.shape[0]):
        x0, x1, x2, x3 = simplices[s, 0], simplices[s, 1], simplices[s, 2], simplices[s, 3]
        p0, p1, p2 = points[x0, 0], points[x0, 1], points[x0, 2]
        e00, e01, e02 = points[x1, 0] - p0, points[x1, 1] - p1, points[x1, 2] - p2
        e10, e11, e12 = points[x2, 0] - p0, points[x2, 1] - p1, points[x2, 2] - p2
        e20, e21, e22 = points[x3, 0] - p0, points[x3, 1] - p1, points[x3, 2] - p2
        g00 = 0.0 + e00 * e00 + e01 * e01 + e02 * e02
        g01 = 0.0 + e00 * e10 + e01 * e11 + e02 * e12
        g02 = 0.0 + e00 * e20 + e01 * e21 + e02 * e22
        g11 = 0.0 + e10 * e10 + e11 * e11 + e12 * e12
        g12 = 0.0 + e10 * e20 + e11 * e21 + e12 * e22
        g22 = 0.0 + e20 * e20 + e21 * e21 + e22 * e22
        scale = (0.0 + g00 + g11 + g22) / k
        c00 = g11 * g22 - g12 * g12
        c01 = g02 * g12 - g01 * g22
        c02 = g01 * g12 - g02 * g11
        det = g00 * c00 + g01 * c01 + g02 * c02
        bad = not (det > (rtol * scale) ** k)
        vol[s] = np.nan if bad else np.sqrt(det) / norm
        if not with_gradients:
            continue
        c11 = g00 * g22 - g02 * g02
        c12 = g01 * g02 - g00 * g12
        c22 = g00 * g11 - g01 * g01
        inv_det = 0.0 if bad else 1.0 / det
        m00, m01, m02 = c00 * inv_det, c01 * inv_det, c02 * inv_det
        m11, m12, m22 = c11 * inv_det, c12 * inv_det, c22 * inv_det
        _tet_gradient(grads, s, 0, e00, e10, e20, m00, m01, m02, m11, m12, m22)
        _tet_gradient(grads, s, 1, e01, e11, e21, m00, m01, m02, m11, m12, m22)
        _tet_gradient(grads, s, 2, e02, e12, e22, m00, m01, m02, m11, m12, m22)


@kernel("void(f8[:, ::1], i8[:, ::1], f8, f8[:, :, ::1], f8[::1], b1)")
@numba.njit(cache=True, nogil=True)
def _small_geometry(points, simplices, rtol, grads, vol, with_gradients):  # pragma: no cover - compiled
    E, k1 = simplices.shape
    k = k1 - 1
    dim = points.shape[1]
    norm = 1.0
    for i in range(2, k + 1):
        norm *= i
    e = np.empty((3, dim))
    g = np.empty((3, 3))
    c = np.empty((3, 3))
    for s in range(E):
        x0 = simplices[s, 0]
        for i in range(k):
            xi = simplices[s, i + 1]
            for d in range(dim):
                e[i, d] = points[xi, d] - points[x0, d]
        for i in range(k):
            for j in range(i, k):
                t = 0.0
                for d in range(dim):
                    t += e[i, d] * e[j, d]
                g[i, j] = t
                g[j, i] = t
        scale = 0.0
        for i in range(k):
            scale += g[i, i]
        scale /= k
        if k == 1:
            det = g[0, 0]
            c[0, 0] = 1.0
        elif k == 2:
            det = g[0, 0] * g[1, 1] - g[0, 1] * g[0, 1]
            c[0, 0] = g[1, 1]
            c[0, 1] = -g[0, 1]
            c[1, 1] = g[0, 0]
        else:
            c[0, 0] = g[1, 1] * g[2, 2] - g[1, 2] * g[1, 2]
            c[0, 1] = g[0, 2] * g[1, 2] - g[0, 1] * g[2, 2]
            c[0, 2] = g[0, 1] * g[1, 2] - g[0, 2] * g[1, 1]
            c[1, 1] = g[0, 0] * g[2, 2] - g[0, 2] * g[0, 2]
            c[1, 2] = g[0, 1] * g[0, 2] - g[0, 0] * g[1, 2]
            c[2, 2] = g[0, 0] * g[1, 1] - g[0, 1] * g[0, 1]
            det = g[0, 0] * c[0, 0] + g[0, 1] * c[0, 1] + g[0, 2] * c[0, 2]
        bad = not (det > (rtol * scale) ** k)
        vol[s] = np.nan if bad else np.sqrt(det) / norm
        if not with_gradients:
            continue
        inv_det = 0.0 if bad else 1.0 / det
        for d in range(dim):
            grads[s, d, 0] = 0.0
        for i in range(k):
            for d in range(dim):
                row = 0.0
                for j in range(k):
                    row += e[j, d] * (c[min(i, j), max(i, j)] * inv_det)
                grads[s, d, i + 1] = row
                grads[s, d, 0] -= row


def _geometry_pass(k1, dim):
    """The compiled pass for simplices of ``k1`` vertices in ``dim`` dimensions: chosen
    here rather than inside one compiled function, so each kind compiles only its own.
    """
    return _tet_geometry if k1 == 4 and dim == 3 else _small_geometry


def small_simplex_volumes(points, simplices, rtol):
    """Volumes ``sqrt(det(E^T E)) / k!`` of simplices of at most 3 dimensions, NaN for the
    degenerate ones (Gram determinant at most ``(rtol * scale)^k``, ``scale`` the mean
    squared edge length from the first vertex), without their gradients.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_geometry import small_simplex_volumes
    >>> tet = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> small_simplex_volumes(tet, np.array([[0, 1, 2, 3], [0, 1, 2, 2]]), 1e-10).round(6).tolist()
    [0.166667, nan]
    """
    simplices = np.ascontiguousarray(simplices)
    vol = np.empty(simplices.shape[0])
    grads = np.empty((0, 0, 0))
    _geometry_pass(simplices.shape[1], points.shape[1])(
        np.ascontiguousarray(points, dtype=np.float64), simplices, float(rtol), grads, vol, False
    )
    return vol


def small_simplex_geometry_compiled(points, simplices, rtol):
    """Barycentric gradients (E, dim, k+1) and volumes (E,) of simplices of at most 3
    dimensions, as :func:`~ndboundary.domains.simplex_geometry.simplex_geometry` gives them
    (zero gradients and NaN volumes for the degenerate ones), in one pass.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_geometry import small_simplex_geometry_compiled
    >>> triangle = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> grads, vol = small_simplex_geometry_compiled(triangle, np.array([[0, 1, 2]]), 1e-10)
    >>> grads[0].tolist(), vol.tolist()
    ([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]], [0.5])
    """
    simplices = np.ascontiguousarray(simplices)
    points = np.ascontiguousarray(points, dtype=np.float64)
    E, k1 = simplices.shape
    if k1 > 4:
        raise ValueError(f"simplices has shape {simplices.shape}; this pass takes at most 4 vertices per simplex")
    vol = np.empty(E)
    grads = np.empty((E, points.shape[1], k1))
    _geometry_pass(k1, points.shape[1])(points, simplices, float(rtol), grads, vol, True)
    return grads, vol


@kernel("void(f8[:, ::1], i8[:, ::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _full_volumes(points, simplices, out):  # pragma: no cover - compiled
    k = simplices.shape[1] - 1
    for s in range(simplices.shape[0]):
        x0 = simplices[s, 0]
        if k == 1:
            out[s] = abs(points[simplices[s, 1], 0] - points[x0, 0])
        elif k == 2:
            a0, a1 = points[simplices[s, 1], 0] - points[x0, 0], points[simplices[s, 1], 1] - points[x0, 1]
            b0, b1 = points[simplices[s, 2], 0] - points[x0, 0], points[simplices[s, 2], 1] - points[x0, 1]
            out[s] = abs(a0 * b1 - a1 * b0) / 2.0
        else:
            p0, p1, p2 = points[x0, 0], points[x0, 1], points[x0, 2]
            x1, x2, x3 = simplices[s, 1], simplices[s, 2], simplices[s, 3]
            a0, a1, a2 = points[x1, 0] - p0, points[x1, 1] - p1, points[x1, 2] - p2
            b0, b1, b2 = points[x2, 0] - p0, points[x2, 1] - p1, points[x2, 2] - p2
            c0, c1, c2 = points[x3, 0] - p0, points[x3, 1] - p1, points[x3, 2] - p2
            out[s] = abs(a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)) / 6.0


def full_simplex_volumes(points, simplices):
    """Unsigned volumes ``|det E| / k!`` of full-dimensional simplices (``k == dim <= 3``)
    in one pass, where the vectorised version gathers every simplex's edge matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_geometry import full_simplex_volumes
    >>> tet = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 3]])
    >>> full_simplex_volumes(tet, np.array([[0, 1, 2, 3], [1, 0, 2, 3]])).tolist()
    [0.5, 0.5]
    """
    simplices = np.ascontiguousarray(simplices, dtype=np.int64)
    if not simplices.shape[1] - 1 == points.shape[1] <= 3:
        raise ValueError(
            f"full_simplex_volumes takes k == dim <= 3, got {simplices.shape[1]} vertices in {points.shape[1]}-D"
        )
    out = np.empty(simplices.shape[0])
    _full_volumes(np.ascontiguousarray(points, dtype=np.float64), simplices, out)
    return out


@kernel("void(f8[:, ::1], i8[:, ::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _longest(points, simplices, out):  # pragma: no cover - compiled
    k1 = simplices.shape[1]
    for s in range(simplices.shape[0]):
        most = 0.0
        for i in range(k1):
            for j in range(i + 1, k1):
                sq = 0.0
                for d in range(points.shape[1]):
                    diff = points[simplices[s, i], d] - points[simplices[s, j], d]
                    sq += diff * diff
                most = max(most, sq)
        out[s] = np.sqrt(most)


def longest_edges(points, simplices):
    """The longest edge of every simplex, in one pass.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_geometry import longest_edges
    >>> longest_edges(np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 4.0]]), np.array([[0, 1, 2]])).tolist()
    [5.0]
    """
    out = np.empty(simplices.shape[0])
    _longest(np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(simplices), out)
    return out


@kernel("void(f8[:, :, ::1], f8[::1], f8[:, ::1], f8[:, ::1])")
@numba.njit(cache=True, nogil=True)
def _stiffness_terms(grads, vol, off, diag):  # pragma: no cover - compiled
    n, dim, k1 = grads.shape
    for e in range(n):
        p = 0
        for i in range(k1):
            for j in range(i + 1, k1):
                t = 0.0
                for d in range(dim):
                    t += grads[e, d, i] * grads[e, d, j]
                off[e, p] = t * vol[e]
                p += 1
            t = 0.0
            for d in range(dim):
                t += grads[e, d, i] * grads[e, d, i]
            diag[e, i] = t * vol[e]


def stiffness_terms_compiled(grads, vol):
    """:func:`~ndboundary.domains.simplex_geometry.stiffness_terms` in one pass: the entries
    ``vol g_i . g_j`` over the vertex pairs ``i < j`` in ``triu_indices`` order, and the
    diagonal ones.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_geometry import small_simplex_geometry_compiled, stiffness_terms_compiled
    >>> tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> grads, vol = small_simplex_geometry_compiled(tri, np.array([[0, 1, 2]]), 1e-10)
    >>> off, diag = stiffness_terms_compiled(grads, vol)
    >>> off.tolist(), diag.tolist()
    ([[-0.5, -0.5, 0.0]], [[1.0, 0.5, 0.5]])
    """
    n, _, k1 = grads.shape
    off = np.empty((n, k1 * (k1 - 1) // 2))
    diag = np.empty((n, k1))
    _stiffness_terms(np.ascontiguousarray(grads), np.ascontiguousarray(vol, dtype=np.float64), off, diag)
    return off, diag


@numba.njit(cache=True, nogil=True, inline="always")
def _det3(M):  # pragma: no cover - compiled
    """The determinant of the 3 x 3 ``M``, written out as ``ndboundary.levelset._det`` is."""
    out = M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1])
    out -= M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
    out += M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0])
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def _det_small(M, n):  # pragma: no cover - compiled
    """The determinant of the leading ``n`` x ``n`` block of ``M``, ``n`` at most 3."""
    if n == 1:
        return M[0, 0]
    if n == 2:
        return M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    return _det3(M)


@kernel("void(f8[:, ::1], f8[::1], i8[:, ::1], i8[::1], i1[:, :, ::1], f8[:, ::1], f8[::1], b1, f8[::1])")
@numba.njit(cache=True, nogil=True)
def crossing_orientations(points, values, S, owner, local, t, own, full, out):  # pragma: no cover - compiled
    """For each output simplex of a level set whose owners have at most 3 dimensions, the
    sign of its orientation against the function's gradient in the reference coordinates
    of its owner ``S[owner]``, times the owner's own orientation: the sign of its volume
    (from ``points``) where ``full``, ``own[owner]`` otherwise. The determinants of its
    edges and the gradient, one simplex at a time, with the same operations as
    ``ndboundary.levelset._orientation``'s arrays and written-out determinants, without
    those arrays.

    ``local[s, j]`` holds the owner's local vertices ``(a, b)`` of the edge that output
    vertex ``j`` lies on, at ``t[s, j]`` from ``a`` to ``b``.
    """
    m, k = t.shape
    n = S.shape[1] - 1  # == k: the reference coordinates' dimension
    xi = np.zeros((k, n))
    M = np.zeros((n, n))
    E = np.zeros((n, n))
    for s in range(m):
        o = owner[s]
        for j in range(k):
            a, b, tj = local[s, j, 0], local[s, j, 1], t[s, j]
            for c in range(1, n + 1):
                xi[j, c - 1] = ((1.0 - tj) if a == c else 0.0) + (tj if b == c else 0.0)
        for j in range(1, k):
            for c in range(n):
                M[j - 1, c] = xi[j, c] - xi[0, c]
        f0 = values[S[o, 0]]
        for c in range(n):
            M[k - 1, c] = values[S[o, c + 1]] - f0
        if full:
            p0 = S[o, 0]
            for r in range(n):
                for c in range(n):
                    E[r, c] = points[S[o, r + 1], c] - points[p0, c]
            sign = np.sign(_det_small(E, n))
        else:
            sign = own[o]
        out[s] = np.sign(_det_small(M, n)) * sign


@numba.njit(cache=True, nogil=True, inline="always")
def _sorted_row(simplices, s, row):  # pragma: no cover - compiled
    """Simplex ``s``'s vertices sorted into ``row`` (insertion): the parity of the
    permutation, +1 even, -1 odd.
    """
    k1 = row.size
    parity = 1
    for i in range(k1):
        v = simplices[s, i]
        j = i
        while j > 0 and row[j - 1] > v:
            row[j] = row[j - 1]
            j -= 1
            parity = -parity
        row[j] = v
    return parity


_CROSSING_PATTERN = (
    "Tuple((i8[:, ::1], i8[::1], i8[:, :, ::1], i8[::1], i1[:, :, ::1]))"
    "(i8[:, ::1], b1[::1], i1[:, :, :, ::1], i8[::1])"
)


@kernel(_CROSSING_PATTERN)
@numba.njit(cache=True, nogil=True)
def crossing_pattern(simplices, above, table, n_paths):  # pragma: no cover - compiled
    """The simplices that a level set crosses and the output simplices each one holds.

    A simplex is crossed when some but not all of its vertices are ``above``. Its vertices
    sorted, ``code`` sets bit ``i`` when sorted vertex ``i`` is above; ``table[code, p]``
    (the first ``n_paths[code]`` of them) lists output simplex ``p``'s vertices as pairs
    of local positions (below, above), the edges they lie on.

    Returns ``(S, parity, E, owner, local)``: the crossed simplices with sorted vertices,
    in their order, and the parity of each sort (+1 even, -1 odd); for each output
    simplex its directed edges (global vertices, below then above), its owner (a row of
    ``S``) and the edges' local positions. Output simplices come grouped by code
    (increasing), then by path, then in their owners' order, as ``marching_simplices``
    lays them out.
    """
    n, k1 = simplices.shape
    n_codes = table.shape[0]
    k = table.shape[2]
    codes = np.empty(n, dtype=np.int16)
    counts = np.zeros(n_codes, dtype=np.int64)
    row = np.empty(k1, dtype=np.int64)
    for s in range(n):
        count = 0
        for i in range(k1):
            if above[simplices[s, i]]:
                count += 1
        if count == 0 or count == k1:
            codes[s] = -1
            continue
        _sorted_row(simplices, s, row)
        code = 0
        for i in range(k1):
            if above[row[i]]:
                code |= 1 << i
        codes[s] = code
        counts[code] += 1
    starts = np.zeros(n_codes, dtype=np.int64)  # the first output simplex of each code
    m = 0
    n_cut = 0
    for c in range(n_codes):
        starts[c] = m
        m += counts[c] * n_paths[c]
        n_cut += counts[c]
    S = np.empty((n_cut, k1), dtype=np.int64)
    parity = np.empty(n_cut, dtype=np.int64)
    E = np.empty((m, k, 2), dtype=np.int64)
    owner = np.empty(m, dtype=np.int64)
    local = np.empty((m, k, 2), dtype=np.int8)
    seen = np.zeros(n_codes, dtype=np.int64)  # owners of each code placed so far
    o = 0
    for s in range(n):
        code = codes[s]
        if code < 0:
            continue
        parity[o] = _sorted_row(simplices, s, row)
        for i in range(k1):
            S[o, i] = row[i]
        for p in range(n_paths[code]):
            out = starts[code] + p * counts[code] + seen[code]
            owner[out] = o
            for j in range(k):
                a = table[code, p, j, 0]
                b = table[code, p, j, 1]
                local[out, j, 0] = a
                local[out, j, 1] = b
                E[out, j, 0] = row[a]
                E[out, j, 1] = row[b]
        seen[code] += 1
        o += 1
    return S, parity, E, owner, local
