"""Vertex functions of a kNN point cloud evaluated at new points.

The neighbour-weighted first-order extension
``sum_j w_j (phi_j + grad phi_j . T_j^T (x - x_j)) / sum_j w_j`` over the ``k`` training
points nearest to ``x``, with tangent gradients and frames ``T_j`` and weights
``w_j = (1 - d_j^2 / d_{k+1}^2) (d_1 / d_j)^p``, ``d_j`` the distance to the ``j``-th
nearest and ``d_{k+1}`` to the next one: a neighbour's weight fades to 0 before it
leaves the set, so the extension is continuous in ``x``. The power ``p`` sets how
sharply it follows the nearest samples; ``power="auto"`` chooses it by the leave-one-out
accuracy of the extension at labelled training samples, which needs no refit since
``phi`` stays as fitted.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EXTENSION_POWERS", "NeighborExtension"]

#: The powers ``power="auto"`` chooses from; on equal leave-one-out accuracy the
#: earlier one is kept.
EXTENSION_POWERS = (0.0, 2.0, 4.0, 8.0, 16.0, 32.0)
_CHUNK = 8192


def _weighted_mean(vals, taper, log_ratio, power):
    """Weighted mean over neighbours of ``vals`` (b, q, r): weights ``taper (d_1 / d_q)^power``."""
    w = taper * np.exp(-power * log_ratio)
    return np.einsum("bq,bqr->br", w, vals) / w.sum(axis=1)[:, None]


def _predicted(phi):
    """Class codes of extension values: ``phi > 1/2`` for one column, the largest otherwise."""
    return (phi[:, 0] > 0.5).astype(np.int64) if phi.shape[1] == 1 else np.argmax(phi, axis=1)


class NeighborExtension:
    """The first-order extension of vertex functions of a point cloud to new points.

    Parameters
    ----------
    cloud : PointCloud
    phi : ndarray of shape (n_samples, n_functions)
        The functions at the cloud's points.
    n_neighbors : int, default=25
        Nearest training samples averaged at a new point.
    power : float or "auto", default="auto"
        Power ``p`` of the weights (module docstring); ``"auto"`` picks the one of
        :data:`EXTENSION_POWERS` whose leave-one-out extension labels the most samples
        of ``labels`` right.
    labels : ndarray of int of shape (n_samples,), optional
        Class codes (column indices; for one function, 0 and 1); needed by ``"auto"``.
    labelled : ndarray of bool of shape (n_samples,), optional
        The samples whose labels count; by default all.

    Attributes
    ----------
    power : float
        The power used.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> X = np.random.default_rng(0).normal(size=(300, 2))
    >>> cloud = PointCloud(X, n_neighbors=10)
    >>> ext = cloud.extension(X[:, :1], power=0.0)
    >>> bool(abs(ext(np.array([[0.1, 0.2]]))[0, 0] - 0.1) < 1e-6)
    True
    """

    def __init__(self, cloud, phi, *, n_neighbors=25, power="auto", labels=None, labelled=None):
        self.cloud = cloud
        self.n_neighbors = int(n_neighbors)
        phi = np.asarray(phi, dtype=np.float64).reshape(cloud.n_vertices, -1)
        u = cloud.unique_inverse
        n_u = cloud.unique_points.shape[0]
        cnt = np.bincount(u, minlength=n_u).astype(np.float64)
        self._phi_u = np.stack([np.bincount(u, weights=p, minlength=n_u) for p in phi.T], axis=1) / cnt[:, None]
        grads = []
        for p in phi.T:
            g = cloud.gradient(p)[: cloud.points.shape[0]]  # (N, m)
            gu = np.stack([np.bincount(u, weights=g[:, a], minlength=n_u) for a in range(g.shape[1])], axis=1)
            grads.append(gu / cnt[:, None])
        self._grad_u = np.stack(grads, axis=1)  # (n_u, r, m)
        self._loo = None
        if power == "auto":
            if labels is None:
                raise ValueError("power='auto' chooses the power by leave-one-out accuracy: it needs labels")
            self.power, self._loo = self._choose_power(np.asarray(labels), labelled)
        else:
            self.power = float(power)

    def __call__(self, X):
        """The functions at the points ``X`` (n, n_features): shape (n, n_functions)."""
        X = np.asarray(X, dtype=np.float64)
        out = np.empty((X.shape[0], self._phi_u.shape[1]))
        for c, *terms in self._terms(X):
            out[c] = _weighted_mean(*terms, self.power)
        return out

    def leave_one_out(self, rows):
        """The extension at the training samples ``rows``, each one's own point left out:
        shape (len(rows), n_functions).
        """
        if self._loo is not None and np.array_equal(rows, self._loo[0]):
            return self._loo[1]
        rows = np.asarray(rows)
        out = np.empty((rows.size, self._phi_u.shape[1]))
        for c, *terms in self._terms(self.cloud.points[rows], rows=rows):
            out[c] = _weighted_mean(*terms, self.power)
        return out

    def _choose_power(self, labels, labelled):
        """``(power, (rows, loo))``: the power of :data:`EXTENSION_POWERS` whose leave-one-out
        extension labels the most labelled samples right, and that extension there.
        """
        rows = np.arange(labels.shape[0]) if labelled is None else np.flatnonzero(labelled)
        right = np.zeros(len(EXTENSION_POWERS), dtype=np.int64)
        loo = np.empty((len(EXTENSION_POWERS), rows.size, self._phi_u.shape[1]))
        for c, *terms in self._terms(self.cloud.points[rows], rows=rows):
            for i, p in enumerate(EXTENSION_POWERS):
                phi = loo[i, c] = _weighted_mean(*terms, p)
                right[i] += int((_predicted(phi) == labels[rows[c]]).sum())
        best = int(np.argmax(right))  # the first of equals
        return float(EXTENSION_POWERS[best]), (rows, loo[best])

    def _terms(self, X, rows=None):
        """Per chunk of ``X``: ``(slice, vals, taper, log_ratio)``.

        ``vals[b, q]`` is the first-order extension of ``phi`` from the ``q``-th nearest
        training sample of ``X[b]``, at distance ``d_q``; ``taper = 1 - (d_q / d_{k+1})^2``
        measures it against the next neighbour's distance (a weight that reaches 0 where a
        neighbour leaves the ``k`` nearest) and ``log_ratio = log(d_q / d_1)``.

        With ``rows``, ``X`` holds those training samples and each sample's own point is
        left out. Those leave-one-out estimates read the neighbours from the graph (the
        nearest other distinct points) instead of querying the index, unless the
        extension uses more neighbours than the graph holds.
        """
        dom = self.cloud
        n_u = dom.unique_points.shape[0]
        own = 0 if rows is None else 1
        k = min(self.n_neighbors, n_u - own)
        nxt = 1 if k + own < n_u else 0  # a (k+1)-th neighbour exists
        for a in range(0, X.shape[0], _CHUNK):
            c = slice(a, min(X.shape[0], a + _CHUNK))
            if rows is not None and k + nxt <= dom.neighbors.shape[1]:
                u = dom.unique_inverse[rows[c]]
                ind, dist = dom.neighbors[u, : k + nxt], dom.distances[u, : k + nxt]
            else:
                ind, dist = dom.kneighbors(X[c], k + nxt + own)
                ind, dist = ind[:, own:], dist[:, own:]
            far = np.maximum(dist[:, -1:], np.finfo(np.float64).tiny)
            if nxt:
                t = dist[:, :k] / far
                taper = np.clip(1.0 - t * t, 0.0, 1.0) + 1e-12  # all k tied with the next: even
            else:
                taper = np.ones((ind.shape[0], k))
            # a point on a training sample (d_1 = 0) takes that sample's value
            log_ratio = np.log(np.maximum(dist[:, :k], 1e-12 * far) / np.maximum(dist[:, :1], 1e-12 * far))
            ind = ind[:, :k]
            off = dom.tangent_offsets(X[c], ind)  # (b, q, m)
            yield c, self._phi_u[ind] + np.einsum("bqrm,bqm->bqr", self._grad_u[ind], off), taper, log_ratio
