"""Labels of unlabelled samples, and neighbourhood voting, over a domain's graph."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import laplacian
from scipy.sparse.linalg import splu

__all__ = ["HARMONIC_NEIGHBORS", "harmonic_labels", "vote"]

#: Neighbours per sample of the graph on which unlabelled samples get their labels: label
#: propagation wants a sparser graph than the relaxation's stencils (figures in the README).
HARMONIC_NEIGHBORS = 15


def _symmetric_graph(edges, n):
    W = sp.csr_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n, n))
    W = W + W.T
    W.data[:] = 1.0
    return W.tocsr()


def harmonic_labels(domain, codes, labelled):
    """Fill the unlabelled codes by the harmonic extension of the labelled class indicators.

    The graph Laplacian of the domain's :meth:`~ndboundary.Domain.propagation_edges` is
    solved with the labelled samples fixed; each unlabelled sample takes the class of its
    largest indicator. A small shift keeps components without labels solvable: they take
    the class prior.

    Parameters
    ----------
    domain : Domain
        Over the samples (one vertex each).
    codes : ndarray of int of shape (n_samples,)
        Class codes; the unlabelled entries are ignored.
    labelled : ndarray of bool of shape (n_samples,)

    Returns
    -------
    ndarray of int of shape (n_samples,)

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> from ndboundary.learn import harmonic_labels
    >>> X = np.r_[np.zeros((20, 2)), np.ones((20, 2))] + np.random.default_rng(0).normal(0, .05, (40, 2))
    >>> codes = np.r_[np.zeros(20, int), np.ones(20, int)]
    >>> known = np.zeros(40, bool); known[[0, 39]] = True
    >>> bool((harmonic_labels(PointCloud(X, n_neighbors=5), codes, known) == codes).all())
    True
    """
    n = codes.shape[0]
    L = laplacian(_symmetric_graph(domain.propagation_edges(HARMONIC_NEIGHBORS), n)).tocsr()
    u = ~labelled
    Luu = L[u][:, u]
    Lul = L[u][:, labelled]
    n_cls = int(codes[labelled].max()) + 1
    F = np.zeros((labelled.sum(), n_cls))
    F[np.arange(F.shape[0]), codes[labelled]] = 1.0
    prior = F.mean(axis=0)
    eps = 1e-8 * max(float(L.diagonal().mean()), 1.0)
    rhs = -(Lul @ F) + eps * prior[None, :]
    lu = splu((Luu + eps * sp.identity(Luu.shape[0])).tocsc())
    Fu = lu.solve(np.asarray(rhs))
    out = codes.copy()
    out[u] = np.argmax(Fu, axis=1)
    return out


def vote(neighborhoods, codes, n_classes, passes, threshold):
    """Codes after ``passes`` passes of neighbourhood voting.

    A pass gives a sample the most frequent code over the rows of ``neighborhoods``
    (the sample and its neighbours) when that code holds at least ``threshold`` of them.

    Parameters
    ----------
    neighborhoods : sparse matrix of shape (n_samples, n_samples)
        Row ``i``: sample ``i`` and its neighbours.
    codes : ndarray of int of shape (n_samples,)
    n_classes : int
    passes : int
    threshold : float

    Returns
    -------
    ndarray of int of shape (n_samples,)

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary.learn import vote
    >>> path = sp.diags([1.0, 1.0, 1.0], [-1, 0, 1], shape=(5, 5)).tocsr()
    >>> vote(path, np.array([0, 0, 1, 0, 0]), 2, 1, 2 / 3).tolist()
    [0, 0, 0, 0, 0]
    """
    n = codes.shape[0]
    rows = np.arange(n)
    for _ in range(passes):
        F = np.zeros((n, n_classes))
        F[rows, codes] = 1.0
        F = neighborhoods @ F
        F = F / F.sum(axis=1, keepdims=True)
        F[rows, codes] += 1e-9
        best = np.argmax(F, axis=1)
        codes = np.where(F[rows, best] >= threshold - 1e-12, best, codes)
    return codes
