"""Poisson learning (Calder, Cook, Thorpe, Slepcev, ICML 2020) as GraphLearning runs it.

A re-implementation of ``graphlearning.ssl.poisson(W).fit_predict(train_ind, train_labels)``
with ``W = graphlearning.weightmatrix.knn(X, 10)``, every option at its default, read
from GraphLearning's sources (github.com/jwcalder/GraphLearning; as released in
``graphlearning`` 1.7.5):

- ``graphlearning/weightmatrix.py``, ``knn`` and ``knnsearch``: the ``k`` nearest
  neighbours of each sample, itself one of them; the ``'gaussian'`` kernel
  ``w_ij = exp(-4 |x_i - x_j|^2 / d_k(x_i)^2)`` with ``d_k(x_i)`` the distance to the
  k-th of them (the (k - 1)-th other sample); symmetrised as ``(W + W^T) / 2``;
  self-loops dropped (``setdiag(0)``).
- ``graphlearning/ssl.py``, ``poisson._fit`` (default ``solver='conjugate_gradient'``,
  ``tol=1e-3``): the source term ``b = sum_j delta_j (y_j - mean(y))`` (one-hot labels,
  centred by their mean over the labelled samples); ``L u = b`` with ``L = D - W``,
  solved as ``u = D^-1/2 x`` with ``x`` the conjugate-gradient solution of
  ``(I - D^-1/2 W D^-1/2) x = D^-1/2 b`` from ``x = 0``.
- ``graphlearning/utils.py``, ``conjgrad`` (``max_iter=1e5``): the iteration stops once
  the residual's Frobenius norm over all classes is at most ``tol``.
- ``graphlearning/graph.py``, ``laplacian(normalization='normalized')`` and
  ``degree_matrix``: ``D`` from the row sums of ``W``.
- ``graphlearning/ssl.py``, ``ssl.predict``: the class with the largest score (after a
  global affine map of the scores, which does not change the choice). No ``class_priors``
  are given by default, so no class-mass / volume rescaling is applied.

One difference: GraphLearning searches the neighbours of data of more than 5 features
with annoy (approximate); this module searches them exactly, with the ``cKDTree`` query
GraphLearning itself uses for ``method='kdtree'``. Given that search
(``knn(X, 10, knn_data=knnsearch(X, 10, method='kdtree'))``), the package's weights and
predictions are this module's: the same predictions on 30 draws of the digits with 1, 3
and 5 labels per class.

Usage::

    from poisson_learning import poisson_learning
    labels = poisson_learning(X, labelled_idx, labelled_y)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree


def knn_weight_matrix(X, k=10):
    """``graphlearning.weightmatrix.knn(X, k)``: symmetric Gaussian kNN weights, zero diagonal."""
    X = np.asarray(X, dtype=np.float64)
    n = X.shape[0]
    k = min(k, n)  # the sample itself is one of its k neighbours
    dist, ind = cKDTree(X).query(X, k=k)
    D = dist * dist
    eps = D[:, k - 1]
    weights = np.exp(-4 * D / eps[:, None])
    rows = np.repeat(np.arange(n), k)
    W = sp.coo_matrix((weights.ravel(), (rows, ind.ravel())), shape=(n, n)).tocsr()
    W = (W + W.T) / 2
    W.setdiag(0)
    W.eliminate_zeros()
    return W.tocsr()


def conjgrad(A, b, tol=1e-3, max_iter=100_000):
    """``graphlearning.utils.conjgrad``: CG on all columns at once, stopping on the total residual."""
    x = np.zeros_like(b)
    r = b - A @ x
    p = r.copy()
    rsold = np.sum(r**2, axis=0)
    err, i = 1.0, 0
    while err > tol and i < max_iter:
        i += 1
        Ap = A @ p
        alpha = rsold / np.sum(p * Ap, axis=0)
        x += alpha * p
        r -= alpha * Ap
        rsnew = np.sum(r**2, axis=0)
        err = np.sqrt(np.sum(rsnew))
        p = r + (rsnew / rsold) * p
        rsold = rsnew
    return x


def poisson_scores(W, labelled_idx, codes, n_classes=None, tol=1e-3):
    """Scores ``u`` of shape (n, n_classes) of ``graphlearning.ssl.poisson(W)._fit``.

    ``codes`` are the labelled samples' classes as integers ``0 .. n_classes - 1``.
    """
    W = sp.csr_matrix(W, dtype=np.float64)
    n = W.shape[0]
    W = (W - sp.diags(W.diagonal())).tocsr()
    codes = np.asarray(codes, dtype=np.int64)
    k = max(int(codes.max()) + 1, np.unique(codes).shape[0] if n_classes is None else n_classes)
    onehot = np.zeros((codes.shape[0], k))
    onehot[np.arange(codes.shape[0]), codes] = 1.0
    source = np.zeros((n, k))
    source[np.asarray(labelled_idx)] = onehot - onehot.mean(axis=0)
    d = np.asarray(W.sum(axis=1)).ravel()
    Dm = sp.diags(d**-0.5)
    L = (sp.identity(n) - Dm @ W @ Dm).tocsr()
    return Dm @ conjgrad(L, Dm @ source, tol=tol)


def poisson_learning(X, labelled_idx, labelled_y, n_neighbors=10):
    """Predicted labels of all samples by Poisson learning on ``knn(X, n_neighbors)``.

    Parameters
    ----------
    X : array of shape (n_samples, n_features)
    labelled_idx : array of int
        Indices of the labelled samples.
    labelled_y : array
        Their labels (any values; mapped to ``0 .. n_classes - 1`` and back).
    n_neighbors : int, default=10

    Returns
    -------
    ndarray of shape (n_samples,)
        The labels of the samples, labelled ones included (as predicted, like GraphLearning).
    """
    classes, codes = np.unique(np.asarray(labelled_y), return_inverse=True)
    u = poisson_scores(knn_weight_matrix(X, n_neighbors), labelled_idx, codes.ravel())
    scores = u - u.min()
    scores = scores / scores.max()
    return classes[np.argmax(scores, axis=1)]
