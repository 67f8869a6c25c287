"""Tangent spaces of data points: local PCA frames and least-squares gradient weights."""

from __future__ import annotations

from math import gamma, pi

import numpy as np
import scipy.sparse as sp

from .._threads import in_blocks

__all__ = ["ball_volume", "frame_transport", "local_pca", "lsq_coefficients"]

#: Eigenvalues of the local covariance below this fraction of the largest span no direction.
_EIG_RTOL = 1e-10
#: Tikhonov weight of the least-squares gradient, relative to the mean eigenvalue.
_LSQ_RTOL = 1e-10
# Points per block of the local PCA.
_CHUNK = 4096


def ball_volume(m):
    """Volume of the unit ball in R^m.

    Examples
    --------
    >>> from ndboundary.domains.tangent import ball_volume
    >>> round(ball_volume(1), 6), round(ball_volume(2), 6), round(ball_volume(3), 6)
    (2.0, 3.141593, 4.18879)
    """
    return pi ** (m / 2) / gamma(m / 2 + 1)


def local_pca(points, nbr, m):
    """Tangent coordinates of the neighbour offsets (n, k, m) and frames (n, D, m).

    The leading eigenvectors of each point's offsets ``Y`` (k, D) are taken from the
    smaller of the Gram matrix ``Y Y^T`` (k, k) and the covariance ``Y^T Y`` (D, D): both
    give the same frame ``T`` and coordinates ``Z = Y T`` (up to the sign of a column),
    and in few dimensions with many neighbours the covariance costs far less. Blocks of
    points are computed on several threads.

    Examples
    --------
    A point of the plane ``z = 0`` and its four neighbours: the frame is orthonormal and
    the coordinates give back the offsets.

    >>> import numpy as np
    >>> from ndboundary.domains.tangent import local_pca
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    >>> Z, T = local_pca(pts, np.array([[1, 2, 3, 4]]), 2)
    >>> Z.shape, T.shape, bool(np.allclose(T[0].T @ T[0], np.eye(2))), bool(np.allclose(Z[0] @ T[0].T, pts[1:]))
    ((1, 4, 2), (1, 3, 2), True, True)
    """
    n, k = nbr.shape
    Z = np.empty((n, k, m))
    T = np.empty((n, points.shape[1], m))
    # numpy's batched eigh and products release the GIL: the blocks share the cores
    for _ in in_blocks(n, _CHUNK, lambda c: _pca_block(points, nbr, m, Z, T, c), first_alone=False):
        pass
    return Z, T


def _pca_block(points, nbr, m, Z, T, c):
    """:func:`local_pca` of the points ``c`` (a slice), into ``Z[c]`` and ``T[c]``."""
    k, D = nbr.shape[1], points.shape[1]
    Y = points[nbr[c]] - points[c][:, None, :]  # (b, k, D)
    if D < k:
        w, U = np.linalg.eigh(Y.transpose(0, 2, 1) @ Y)
        w, U = w[:, ::-1][:, :m], U[:, :, ::-1][:, :, :m]
        ok = (w > _EIG_RTOL * np.maximum(w[:, :1], 1e-300))[:, None, :]
        T[c] = np.where(ok, U, 0.0)
        Z[c] = Y @ T[c]
        return
    w, V = np.linalg.eigh(Y @ Y.transpose(0, 2, 1))
    w, V = w[:, ::-1][:, :m], V[:, :, ::-1][:, :, :m]
    ok = w > _EIG_RTOL * np.maximum(w[:, :1], 1e-300)
    sw = np.sqrt(np.where(ok, w, 0.0))
    Z[c] = V * sw[:, None, :]
    T[c] = (Y.transpose(0, 2, 1) @ V) * np.where(ok, 1.0 / np.where(ok, sw, 1.0), 0.0)[:, None, :]


def lsq_coefficients(Z):
    """Least-squares gradient weights ``(Z^T Z)^{-1} Z^T`` per point, (n, m, k).

    Examples
    --------
    The gradient of ``x + 2 y + 3 z`` on the plane ``z = 0``, carried back to space by the frame:

    >>> import numpy as np
    >>> from ndboundary.domains.tangent import local_pca, lsq_coefficients
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    >>> Z, T = local_pca(pts, np.array([[1, 2, 3, 4]]), 2)
    >>> f = pts @ [1.0, 2.0, 3.0]
    >>> (T[0] @ lsq_coefficients(Z)[0] @ (f[1:] - f[0])).round(6).tolist()
    [1.0, 2.0, 0.0]
    """
    ZtZ = Z.transpose(0, 2, 1) @ Z
    m = Z.shape[2]
    tr = np.trace(ZtZ, axis1=1, axis2=2)
    reg = _LSQ_RTOL * np.maximum(tr, 1e-300) / m
    ZtZ = ZtZ + reg[:, None, None] * np.eye(m)
    return np.linalg.solve(ZtZ, Z.transpose(0, 2, 1))


def frame_transport(frames, rows, stencil):
    """The averaging of tangent vectors over stencils, carried between frames.

    Row block ``j`` maps the flattened field to ``sum_i T_j^T T_i X_i`` over ``i`` in
    ``stencil[j]``, ``T_i = frames[rows[i]]``: every neighbour's vector goes into ``j``'s
    frame through the ambient space. Negative entries of ``stencil`` are left out of the
    sums (in a band of a point cloud, the neighbours that are not elements of the band).
    Sparse of shape (N m, N m), ``N = len(stencil)``, ``m`` the frames' width.

    Examples
    --------
    Three points sharing one frame, each with a stencil of two: vectors pass unchanged,
    so a constant field sums to twice itself, or to itself where a neighbour is absent.

    >>> import numpy as np
    >>> from ndboundary.domains.tangent import frame_transport
    >>> frames = np.repeat(np.eye(3)[None, :, :2], 3, axis=0)  # the xy plane, (3, 3, 2)
    >>> M = frame_transport(frames, np.arange(3), np.array([[0, 1], [1, 2], [2, 0]]))
    >>> M.shape, (M @ np.ones(6)).round(6).tolist()
    ((6, 6), [2.0, 2.0, 2.0, 2.0, 2.0, 2.0])
    >>> M = frame_transport(frames, np.arange(3), np.array([[0, 1], [1, -1], [2, 0]]))
    >>> (M @ np.ones(6)).round(6).tolist()
    [2.0, 2.0, 1.0, 1.0, 2.0, 2.0]
    """
    N, k1 = stencil.shape
    m = frames.shape[2]
    present = stencil >= 0
    s = stencil if present.all() else np.where(present, stencil, 0)
    data = np.empty((N, m, k1, m))
    for a in range(0, N, _CHUNK):
        c = slice(a, min(N, a + _CHUNK))
        Tj = frames[rows[c]]  # (b, D, m)
        Ti = frames[rows[s[c]]]  # (b, k1, D, m)
        data[c] = np.einsum("bda,bkdc->bakc", Tj, Ti, optimize=True)
    indices = (s[:, None, :, None] * m + np.arange(m)[None, None, None, :]).repeat(m, axis=1)
    if present.all():
        indptr = np.arange(N * m + 1, dtype=np.int64) * (k1 * m)
        return sp.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(N * m, N * m))
    keep = np.broadcast_to(present[:, None, :, None], data.shape)
    indptr = np.zeros(N * m + 1, dtype=np.int64)
    np.cumsum(np.repeat(present.sum(axis=1) * m, m), out=indptr[1:])
    return sp.csr_matrix((data[keep], indices[keep], indptr), shape=(N * m, N * m))
