"""Labels of unlabelled samples by Poisson learning: the classifier's label-extension stage.

With few labels, Laplace learning (the harmonic extension of the labelled indicators)
degenerates: away from the labelled samples its solution is nearly constant, and a class
can lose every sample but its own labelled ones. Poisson learning (Calder, Cook, Thorpe
and Slepcev, ICML 2020) puts the source term at the labelled samples instead, their
one-hot class indicators centred by their mean, and iterates ``u += D^-1 (b - L u)`` on
a Gaussian kNN graph, stopped when a random walk started on the labelled samples has
mixed. Each unlabelled sample takes the class of its largest score; the relaxation then
runs on those labels.

The graph is GraphLearning's ``knn`` weighting, ``w_ij = exp(-4 |x_i - x_j|^2 / d_k(x_i)^2)``
with ``d_k`` the distance to the k-th neighbour, symmetrised, over the domain's
:meth:`~ndboundary.Domain.propagation_edges`, with 8 neighbours rather than
GraphLearning's 10: on the digits with 1, 3 and 5 labels per class this stage alone then
beats GraphLearning's default Poisson learning on every one of 20 draws not used to
choose it (``benchmarks/few_labels.py`` measures the classifier against it).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["POISSON_ITERATIONS", "POISSON_NEIGHBORS", "poisson_labels"]

#: Neighbours per sample of the Gaussian graph Poisson learning runs on.
POISSON_NEIGHBORS = 8
#: Bounds of the iterations of ``u += D^-1 (b - L u)``; between them the iteration stops
#: once a random walk started uniformly on the labelled samples has mixed (every entry of
#: its distribution within ``1 / n`` of the stationary one), the paper's stopping rule.
POISSON_ITERATIONS = (50, 1000)


def _gaussian_graph(domain, k):
    """GraphLearning's ``knn(X, k)`` weights over the domain's propagation edges, symmetrised.

    ``d_k`` is a point cloud's distance to the k-th nearest other point, or on other
    domains the longest edge at the sample; longer edges (a point cloud's bridges between
    components) weigh as much as a k-th neighbour.
    """
    n = domain.points.shape[0]
    edges = domain.propagation_edges(k)
    i, j = edges[:, 0], edges[:, 1]
    keep = i != j
    i, j = i[keep], j[keep]
    d2 = np.sum((domain.points[i] - domain.points[j]) ** 2, axis=1)
    dist = getattr(domain, "distances", None)
    if dist is not None:  # a point cloud: the sorted neighbour distances of its distinct points
        eps = dist[domain.unique_inverse, min(k, dist.shape[1]) - 1] ** 2
    else:
        eps = np.zeros(n)
        np.maximum.at(eps, i, d2)
        np.maximum.at(eps, j, d2)
    eps = np.where(eps > 0, eps, max(float(d2.max()) if d2.size else 1.0, 1e-300))
    w = np.exp(-4.0 * np.minimum(d2 / eps[i], 1.0))
    W = sp.csr_matrix((w, (i, j)), shape=(n, n))
    return ((W + W.T) / 2).tocsr()


def poisson_labels(domain, codes, labelled, n_neighbors=POISSON_NEIGHBORS):
    """Fill the unlabelled codes by Poisson learning over the domain's graph.

    Parameters
    ----------
    domain : Domain
        Over the samples (one vertex each).
    codes : ndarray of int of shape (n_samples,)
        Class codes; the unlabelled entries are ignored.
    labelled : ndarray of bool of shape (n_samples,)
    n_neighbors : int, default=POISSON_NEIGHBORS

    Returns
    -------
    ndarray of int of shape (n_samples,)

    Examples
    --------
    Three clusters along a line, one labelled sample in each:

    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> from ndboundary.learn.poisson import poisson_labels
    >>> centres = np.repeat([[0.0, 0.0], [3.0, 0.0], [6.0, 0.0]], 30, axis=0)
    >>> cloud = PointCloud(centres + np.random.default_rng(1).normal(0, 0.3, (90, 2)), n_neighbors=10)
    >>> truth = np.repeat([0, 1, 2], 30)
    >>> known = np.isin(np.arange(90), [5, 40, 75])
    >>> float(np.mean(poisson_labels(cloud, np.where(known, truth, 0), known) == truth))
    1.0
    """
    W = _gaussian_graph(domain, n_neighbors)
    n = codes.shape[0]
    idx = np.flatnonzero(labelled)
    n_cls = int(codes[idx].max()) + 1
    F = np.zeros((idx.size, n_cls))
    F[np.arange(idx.size), codes[idx]] = 1.0
    b = np.zeros((n, n_cls))
    b[idx] = F - F.mean(axis=0)
    d = np.asarray(W.sum(axis=1)).ravel()
    dinv = 1.0 / np.where(d > 0, d, 1.0)
    P = (sp.diags(dinv) @ W).tocsr()  # D^-1 W
    walk = (W @ sp.diags(dinv)).tocsr()  # one step of the random walk's distribution
    Db = dinv[:, None] * b
    v = np.zeros(n)
    v[idx] = 1.0 / idx.size
    v_inf = d / max(float(d.sum()), 1e-300)
    lo, hi = POISSON_ITERATIONS
    u = np.zeros((n, n_cls))
    for t in range(hi):
        if t >= lo and np.max(np.abs(v - v_inf)) <= 1.0 / n:
            break
        u = Db + P @ u  # u += D^-1 (b - (D - W) u)
        v = walk @ v
    out = codes.copy()
    out[~labelled] = np.argmax(u[~labelled], axis=1)
    return out
