"""A classifier whose decision boundary is a relaxed level set over the training data.

:class:`LevelSetClassifier` builds one domain over the training samples (a kNN
:class:`~ndboundary.pointcloud.PointCloud`, or a Delaunay complex in low dimension),
takes the class labels as vertex labels and relaxes each class's jagged boundary
against the rest into the level set ``phi = 1/2`` of a smooth function
(:func:`ndboundary.relax`). Since ``grad phi`` is close to unit length, ``phi - 1/2``
behaves like a signed distance (in units of the mean neighbour distance ``h``) to the
relaxed boundary: it is the decision function.

New points get ``phi`` from the fitted function alone, so the prediction of a point
never depends on the other points predicted with it:

* kNN graph: the neighbour-weighted first-order extension
  ``sum_j w_j (phi_j + grad phi_j . T_j^T (x - x_j)) / sum_j w_j`` over the
  ``extension_neighbors`` training points nearest to ``x``, with tangent gradients and
  frames ``T_j`` and weights ``w_j = (1 - d_j^2 / d_{k+1}^2) (d_1 / d_j)^p``, ``d_j``
  the distance to the ``j``-th nearest and ``d_{k+1}`` to the next one, so that a
  neighbour's weight fades to 0 before it leaves the set: the extension is continuous
  in ``x``. The power ``p`` sets how sharply it follows the nearest samples; by default
  it is chosen at fit time by the leave-one-out accuracy of the extension at the
  training samples, which needs no refit since ``phi`` stays as fitted;
* Delaunay: barycentric interpolation in the containing simplex; outside the convex
  hull, the first-order extension from the nearest vertex with its area-weighted
  gradient.
"""

from __future__ import annotations

import numbers
import sys
import time

import numpy as np
import scipy.sparse as sp
from scipy.optimize import minimize_scalar
from scipy.sparse.csgraph import laplacian
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from .pipeline import relax
from .pointcloud import DELAUNAY_MAX_DIM, PointCloud, delaunay_complex

__all__ = ["LevelSetClassifier"]

_CHUNK = 8192
#: ``n_neighbors="auto"``: this many neighbours up to :data:`AUTO_NEIGHBORS_MAX_SAMPLES`
#: samples, then :data:`AUTO_NEIGHBORS_LARGE`.
AUTO_NEIGHBORS = 40
AUTO_NEIGHBORS_MAX_SAMPLES = 20_000
AUTO_NEIGHBORS_LARGE = 15
#: The powers ``extension_power="auto"`` chooses from; on equal leave-one-out accuracy
#: the earlier one is kept.
EXTENSION_POWERS = (0.0, 2.0, 4.0, 8.0, 16.0, 32.0)
#: Neighbours per sample of the graph on which unlabelled samples get their labels.
HARMONIC_NEIGHBORS = 15


class LevelSetClassifier(ClassifierMixin, BaseEstimator):
    """Classify by the relaxed level sets of the class labels over a graph of the samples.

    Parameters
    ----------
    n_neighbors : int or "auto", default="auto"
        Neighbours per sample of the kNN graph. ``"auto"``: :data:`AUTO_NEIGHBORS` (40)
        up to :data:`AUTO_NEIGHBORS_MAX_SAMPLES` (20 000) samples, 15 beyond. On small
        noisy samples the wider stencil steadies the tangent gradients (mean accuracy
        over the ten sets of ``benchmarks/classify.py`` 0.892, against 0.883 with 15 and
        haberman 3.6 points below KNN15); on large ones the graph's cost grows with ``k``
        (its construction took over 180 s at 100 000 samples in 50 dimensions with 40,
        against 32 s with 15) while 15 neighbours already hold the data's shape. The
        value used is ``n_neighbors_``.
    extension_neighbors : int, default=25
        Nearest training samples whose first-order extensions of ``phi`` are averaged
        at a new point (kNN graph only), with weights that fade to 0 at the next
        neighbour's distance: a continuous extension, whose 2-D boundary on the moons is
        shorter than KNN15's (7.2 against 9.0; 10.3 with a plain average over 15).
    extension_power : float or "auto", default="auto"
        Power ``p`` of the factor ``(d_1 / d_j)^p`` of the extension weights (kNN graph
        only, see the module docstring): 0 leaves the fading weights alone (smoothest),
        large values follow the nearest sample (sharpest; in high dimension the
        distances to the neighbours differ little, so sharp needs large powers).
        ``"auto"`` picks the power among :data:`EXTENSION_POWERS` whose extension best
        predicts each training sample's label from its neighbours (leave-one-out, no
        refit). Noisy, overlapping classes pick 0 and sparse high-dimensional ones large
        powers: over the ten sets this gives 0.892 against 0.885 for ``p = 0``
        everywhere. The value used is ``extension_power_``.
    graph : {"knn", "delaunay", "auto"}, default="knn"
        Domain over the samples: a kNN :class:`~ndboundary.pointcloud.PointCloud`, a
        Delaunay complex (2 to 6 features, distinct samples), or ``"auto"``: Delaunay
        for 2 or 3 features and distinct samples, kNN otherwise.
    lam : float, default=1.0
        Weight of the boundary term of the integration (see :func:`ndboundary.relax`):
        larger stays closer to the jagged kNN boundary, smaller relaxes further.
    smoothing : int, default=0
        Field smoothing passes. One pass over a kNN stencil averages about as many
        vectors as several passes over a triangle mesh; on data the field is already
        smooth enough for the relaxation, and every pass moves the boundary away from
        the (voted) labels, at a cost in accuracy (most on high-dimensional data).
    vote : int, default=0
        Passes of neighbourhood voting applied to the training labels before the
        relaxation (0: relax the raw labels). A pass gives a sample the most frequent
        label over the sample and its neighbours when that label holds at least
        ``vote_threshold`` of them, removing isolated labels that would otherwise each
        be enclosed by their own level set: one pass shortens the 2-D boundary on the
        moons but treats a diffuse minority class as noise (ionosphere: a third of one
        class relabelled).
    vote_threshold : float, default=2/3
        Share of the sample and its neighbours a label needs to overrule the sample's
        own label in a voting pass, in ``[0, 1]``. 0 is plurality voting (ties keep the
        label); a qualified majority leaves the labels of samples near a true class
        boundary alone and removes only labels that are isolated among another class.
    tol : float, default=1e-6
        Relative residual of the linear solves of the relaxation. Decisions do not move
        below about 1e-5 (no prediction changed from 1e-10 to 1e-6 on the benchmarks),
        and each decade costs a few more iterations.
    unlabeled : int, float, str or None, default=None
        The label that marks an unlabelled sample (``-1`` to follow
        :class:`~sklearn.semi_supervised.LabelSpreading`). None: every label is a class.
    intrinsic_dim : int or None, default=None
        Tangent dimension of the kNN operators; estimated when None.
    random_state : int, Generator or None, default=None
        Seed of the approximate neighbour search (used beyond 20 000 samples).
    verbose : bool, default=False
        Print progress to stderr.

    Attributes
    ----------
    classes_ : ndarray of shape (n_classes,)
    n_neighbors_ : int
        Neighbours per sample of the kNN graph (0 for a Delaunay complex).
    extension_power_ : float or None
        Power of the extension weights (None for a Delaunay complex).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Only when ``X`` has string column names.
    domain_ : Domain
        The graph over the distinct training samples' coordinates.
    phi_ : ndarray of shape (n_samples, n_relaxations)
        The relaxed functions on the training samples: one column for two classes
        (``phi > 1/2`` means ``classes_[1]``), one per class otherwise.
    transduction_ : ndarray of shape (n_samples,)
        The labels of the training samples, unlabelled ones filled in by
        harmonic extension before the relaxation.
    proba_scale_ : float
        Slope of the logistic map from ``phi`` to probabilities, fitted on
        leave-one-out estimates of ``phi`` at the training samples.

    Notes
    -----
    Semi-supervised use follows :class:`sklearn.semi_supervised.LabelSpreading`:
    with ``unlabeled=-1``, samples with ``y == -1`` are unlabelled (opt-in, so that
    ``-1`` stays an ordinary class label by default). They join the graph, and their labels are
    first given by the harmonic extension of the labelled ones (the graph Laplacian
    solved with the labelled samples fixed), then the relaxation runs on all samples.

    Examples
    --------
    >>> from sklearn.datasets import make_moons
    >>> from ndboundary import LevelSetClassifier
    >>> X, y = make_moons(200, noise=0.2, random_state=0)
    >>> clf = LevelSetClassifier().fit(X, y)
    >>> clf.score(X, y) > 0.9
    True
    """

    def __init__(
        self,
        *,
        n_neighbors="auto",
        extension_neighbors=25,
        extension_power="auto",
        graph="knn",
        lam=1.0,
        smoothing=0,
        vote=0,
        vote_threshold=2 / 3,
        tol=1e-6,
        unlabeled=None,
        intrinsic_dim=None,
        random_state=None,
        verbose=False,
    ):
        self.n_neighbors = n_neighbors
        self.extension_neighbors = extension_neighbors
        self.extension_power = extension_power
        self.graph = graph
        self.lam = lam
        self.smoothing = smoothing
        self.vote = vote
        self.vote_threshold = vote_threshold
        self.tol = tol
        self.unlabeled = unlabeled
        self.intrinsic_dim = intrinsic_dim
        self.random_state = random_state
        self.verbose = verbose

    # -- helpers -------------------------------------------------------------------------
    def _log(self, msg, t0):
        if self.verbose:
            print(f"[LevelSetClassifier] {msg} ({time.perf_counter() - t0:.2f} s)", file=sys.stderr, flush=True)

    def _check_params(self):
        if isinstance(self.n_neighbors, str):
            if self.n_neighbors != "auto":
                raise ValueError(f"n_neighbors must be an integer or 'auto', got {self.n_neighbors!r}")
        elif isinstance(self.n_neighbors, bool) or not isinstance(self.n_neighbors, numbers.Integral):
            raise TypeError(f"n_neighbors must be an integer or 'auto', got {type(self.n_neighbors).__name__}")
        elif self.n_neighbors < 2:
            raise ValueError(f"n_neighbors must be >= 2, got {self.n_neighbors}")
        if isinstance(self.extension_power, str):
            if self.extension_power != "auto":
                raise ValueError(f"extension_power must be a number or 'auto', got {self.extension_power!r}")
        elif isinstance(self.extension_power, bool) or not isinstance(self.extension_power, numbers.Real):
            raise TypeError(
                f"extension_power must be a number or 'auto', got {type(self.extension_power).__name__}"
            )
        elif not 0.0 <= self.extension_power < np.inf:
            raise ValueError(f"extension_power must be finite and >= 0, got {self.extension_power}")
        if isinstance(self.extension_neighbors, bool) or not isinstance(self.extension_neighbors, numbers.Integral):
            raise TypeError(f"extension_neighbors must be an integer, got {type(self.extension_neighbors).__name__}")
        if self.extension_neighbors < 1:
            raise ValueError(f"extension_neighbors must be >= 1, got {self.extension_neighbors}")
        if isinstance(self.vote_threshold, bool) or not isinstance(self.vote_threshold, numbers.Real):
            raise TypeError(f"vote_threshold must be a number, got {type(self.vote_threshold).__name__}")
        if not 0.0 <= self.vote_threshold <= 1.0:
            raise ValueError(f"vote_threshold must be in [0, 1], got {self.vote_threshold}")
        if isinstance(self.tol, bool) or not isinstance(self.tol, numbers.Real):
            raise TypeError(f"tol must be a number, got {type(self.tol).__name__}")
        if not 0.0 < self.tol < 1.0:
            raise ValueError(f"tol must be in (0, 1), got {self.tol}")
        if self.graph not in ("knn", "delaunay", "auto"):
            raise ValueError(f"graph must be 'knn', 'delaunay' or 'auto', got {self.graph!r}")

    def _build_domain(self, X):
        graph = self.graph
        distinct = np.unique(X, axis=0).shape[0] == X.shape[0]
        if graph == "auto":
            graph = "delaunay" if 2 <= X.shape[1] <= 3 and distinct and X.shape[0] > X.shape[1] + 1 else "knn"
        if graph == "delaunay":
            if not 2 <= X.shape[1] <= DELAUNAY_MAX_DIM:
                raise ValueError(
                    f"graph='delaunay' needs 2 to {DELAUNAY_MAX_DIM} features, got {X.shape[1]}; use graph='knn'"
                )
            return delaunay_complex(X), "delaunay"
        k = self.n_neighbors
        if k == "auto":
            k = AUTO_NEIGHBORS if X.shape[0] <= AUTO_NEIGHBORS_MAX_SAMPLES else AUTO_NEIGHBORS_LARGE
        return (
            PointCloud(X, n_neighbors=k, intrinsic_dim=self.intrinsic_dim, random_state=self.random_state),
            "knn",
        )

    def _label_graph(self, domain):
        """Edges on which unlabelled samples get their labels: the Delaunay edges, or each
        sample's :data:`HARMONIC_NEIGHBORS` nearest neighbours (label propagation wants a
        sparse graph: on digits with 5% of the labels, 0.890 accuracy with 15 neighbours
        against 0.818 with the 40 of the relaxation's graph), its duplicates and bridges."""
        if self._graph != "knn":
            return domain.edges
        n = domain.points.shape[0]
        kk = min(HARMONIC_NEIGHBORS, domain.neighbors.shape[1])
        i = np.repeat(np.arange(n), kk)
        j = domain._rep[domain.neighbors[domain.unique_inverse, :kk]].ravel()
        dup = np.flatnonzero(domain._rep[domain.unique_inverse] != np.arange(n))
        i = np.concatenate([i, dup, domain.bridges[:, 0]])
        j = np.concatenate([j, domain._rep[domain.unique_inverse[dup]], domain.bridges[:, 1]])
        return np.stack([i, j], axis=1)

    def _harmonic_labels(self, domain, codes, labelled):
        """Fill unlabelled codes by the harmonic extension of the labelled indicators."""
        n = codes.shape[0]
        e = self._label_graph(domain)
        W = sp.csr_matrix((np.ones(e.shape[0]), (e[:, 0], e[:, 1])), shape=(n, n))
        W = W + W.T
        W.data[:] = 1.0
        L = laplacian(W.tocsr()).tocsr()
        u = ~labelled
        Luu = L[u][:, u]
        Lul = L[u][:, labelled]
        n_cls = int(codes[labelled].max()) + 1
        F = np.zeros((labelled.sum(), n_cls))
        F[np.arange(F.shape[0]), codes[labelled]] = 1.0
        # a small shift keeps components without labels solvable: they get the prior
        prior = F.mean(axis=0)
        eps = 1e-8 * max(float(L.diagonal().mean()), 1.0)
        rhs = -(Lul @ F) + eps * prior[None, :]
        from scipy.sparse.linalg import splu

        lu = splu((Luu + eps * sp.identity(Luu.shape[0])).tocsc())
        Fu = lu.solve(np.asarray(rhs))
        out = codes.copy()
        out[u] = np.argmax(Fu, axis=1)
        return out

    # -- fit -------------------------------------------------------------------------------
    def fit(self, X, y):
        """Build the graph over ``X`` and relax every class's boundary.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
            Class labels; the value ``unlabeled`` (if set) marks an unlabelled sample.

        Returns
        -------
        self : LevelSetClassifier
        """
        self._check_params()
        X, y = validate_data(self, X, y, ensure_min_samples=2, dtype=np.float64)
        check_classification_targets(y)
        t0 = time.perf_counter()
        labelled = np.ones(y.shape[0], dtype=bool)
        if self.unlabeled is not None:
            labelled = y != self.unlabeled
        if not labelled.any():
            raise ValueError(f"y holds no labelled sample (every label is the unlabeled marker {self.unlabeled!r})")
        self.classes_, codes_l = np.unique(y[labelled], return_inverse=True)
        codes = np.full(y.shape[0], -1, dtype=np.int64)
        codes[labelled] = codes_l.reshape(-1)
        n_cls = self.classes_.shape[0]
        self._X = X
        if n_cls == 1 or np.unique(X, axis=0).shape[0] < 2:
            self._constant = int(np.argmax(np.bincount(codes[labelled], minlength=n_cls)))
            self.transduction_ = self.classes_[np.where(labelled, codes, self._constant)]
            self.domain_ = None
            self.phi_ = np.zeros((X.shape[0], 1 if n_cls <= 2 else n_cls))
            self.proba_scale_ = 1.0
            self.n_neighbors_ = 0
            self.extension_power_ = None
            return self
        self._constant = None
        self.domain_, self._graph = self._build_domain(X)
        self.n_neighbors_ = int(self.domain_.n_neighbors) if self._graph == "knn" else 0
        self._log(f"built the {self._graph} graph over {X.shape[0]} samples", t0)
        if not labelled.all():
            codes = self._harmonic_labels(self.domain_, codes, labelled)
            self._log("harmonic extension of the labels", t0)
        self.transduction_ = self.classes_[codes]
        votes = self._vote(codes, n_cls)
        targets = [votes == 1] if n_cls == 2 else [votes == c for c in range(n_cls)]
        phis = []
        for c, target in enumerate(targets):
            if target.all() or not target.any():
                phis.append(np.full(X.shape[0], 1.0 if target.all() else 0.0))
                continue
            res = relax(
                self.domain_, target, on="vertices", lam=self.lam, smoothing=self.smoothing, rtol=self.tol
            )
            phis.append(res.phi)
            self._log(f"relaxed class {c + 1}/{len(targets)}", t0)
        self.phi_ = np.stack(phis, axis=1)
        self._prepare_extension()
        self.extension_power_, loo = self._choose_extension_power(codes, labelled)
        self._log(f"extension power {self.extension_power_}", t0)
        self.proba_scale_ = self._fit_proba_scale(codes, labelled, loo)
        self._log("fitted", t0)
        return self

    def _vote(self, codes, n_cls):
        """Labels after ``vote`` passes of neighbourhood voting with ``vote_threshold``."""
        if self.vote == 0:
            return codes
        n = codes.shape[0]
        inc = self.domain_.incidence[:, :n] if self._graph == "knn" else None
        if inc is None:
            e = self.domain_.edges
            W = sp.csr_matrix((np.ones(e.shape[0]), (e[:, 0], e[:, 1])), shape=(n, n))
            W = (W + W.T + sp.identity(n)).tocsr()
        else:
            W = inc.T.tocsr()
        rows = np.arange(n)
        for _ in range(self.vote):
            F = np.zeros((n, n_cls))
            F[rows, codes] = 1.0
            F = W @ F
            F = F / F.sum(axis=1, keepdims=True)
            F[rows, codes] += 1e-9
            best = np.argmax(F, axis=1)
            codes = np.where(F[rows, best] >= self.vote_threshold - 1e-12, best, codes)
        return codes

    def _prepare_extension(self):
        dom = self.domain_
        if self._graph == "knn":
            u = dom.unique_inverse
            n_u = dom.unique_points.shape[0]
            cnt = np.bincount(u, minlength=n_u).astype(np.float64)
            phi_u = np.stack([np.bincount(u, weights=p, minlength=n_u) for p in self.phi_.T], axis=1) / cnt[:, None]
            grads = []
            for p in self.phi_.T:
                g = dom.gradient(p)[: dom.points.shape[0]]  # (N, m)
                gu = np.stack([np.bincount(u, weights=g[:, a], minlength=n_u) for a in range(g.shape[1])], axis=1)
                grads.append(gu / cnt[:, None])
            self._phi_u = phi_u  # (n_u, r)
            self._grad_u = np.stack(grads, axis=1)  # (n_u, r, m)
        else:
            from scipy.spatial import Delaunay

            from sklearn.neighbors import NearestNeighbors

            self._tri = Delaunay(dom.points)
            self._nn_vertices = NearestNeighbors(n_neighbors=2).fit(dom.points)
            # per-vertex gradient: measure-weighted mean over its simplices
            Gp = []
            inc = dom.incidence.multiply(dom.A[None, :]).tocsr()
            wsum = np.asarray(inc.sum(axis=1)).ravel()
            for p in self.phi_.T:
                g = dom.gradient(p)
                Gp.append(np.asarray(inc @ g) / wsum[:, None])
            self._grad_v = np.stack(Gp, axis=1)  # (n, r, D)

    @staticmethod
    def _extend_with(vals, taper, log_ratio, power):
        """Weighted mean over neighbours of ``vals`` (b, q, r): weights
        ``taper (d_1 / d_q)^power``."""
        w = taper * np.exp(-power * log_ratio)
        return np.einsum("bq,bqr->br", w, vals) / w.sum(axis=1)[:, None]

    def _choose_extension_power(self, codes, labelled):
        """``(power, loo)``: ``extension_power``, or with "auto" the power of
        :data:`EXTENSION_POWERS` whose leave-one-out extension labels the most labelled
        training samples right; ``loo`` is that extension at the labelled samples (None
        when not computed here)."""
        if self._graph != "knn":
            return None, None
        if self.extension_power != "auto":
            return float(self.extension_power), None
        rows = np.flatnonzero(labelled)
        right = np.zeros(len(EXTENSION_POWERS), dtype=np.int64)
        loo = np.empty((len(EXTENSION_POWERS), rows.size, self._phi_u.shape[1]))
        for c, *terms in self._extension_terms(self._X[rows], exclude_self=True, rows=rows):
            for i, p in enumerate(EXTENSION_POWERS):
                phi = loo[i, c] = self._extend_with(*terms, p)
                pred = (phi[:, 0] > 0.5).astype(np.int64) if phi.shape[1] == 1 else np.argmax(phi, axis=1)
                right[i] += int((pred == codes[rows[c]]).sum())
        best = int(np.argmax(right))  # the first of equals
        return float(EXTENSION_POWERS[best]), loo[best]

    def _extension_terms(self, X, exclude_self=False, rows=None):
        """Per chunk of ``X``: ``(slice, vals, taper, log_ratio)``.

        ``vals[b, q]`` is the first-order extension of ``phi`` from the ``q``-th nearest
        training sample of ``X[b]``, at distance ``d_q``; ``taper = 1 - (d_q / d_{k+1})^2``
        measures it against the next neighbour's distance (a weight that reaches 0 where a
        neighbour leaves the ``k`` nearest) and ``log_ratio = log(d_q / d_1)``.

        With ``exclude_self``, ``X`` is the training set (``rows`` of it, default all) and
        each sample's own point is left out. Those leave-one-out estimates read the
        neighbours from the graph (the nearest other distinct points) instead of querying
        the index, unless the extension uses more neighbours than the graph holds.
        """
        dom = self.domain_
        n_u = dom.unique_points.shape[0]
        own = 1 if exclude_self else 0
        k = min(self.extension_neighbors, n_u - own)
        nxt = 1 if k + own < n_u else 0  # a (k+1)-th neighbour exists
        rows = np.arange(X.shape[0]) if rows is None else rows
        for a in range(0, X.shape[0], _CHUNK):
            c = slice(a, min(X.shape[0], a + _CHUNK))
            if exclude_self and k + nxt <= dom.neighbors.shape[1]:
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

    def _extend_knn(self, X, exclude_self=False):
        """First-order extension at ``X`` weighted by ``extension_power_``; with
        ``exclude_self``, ``X`` is the training set (leave-one-out)."""
        out = np.empty((X.shape[0], self._phi_u.shape[1]))
        for c, *terms in self._extension_terms(X, exclude_self):
            out[c] = self._extend_with(*terms, self.extension_power_)
        return out

    def _extend_delaunay(self, X, exclude_self=False):
        dom = self.domain_
        P = dom.points
        out = np.empty((X.shape[0], self.phi_.shape[1]))
        simplex = self._tri.find_simplex(X) if not exclude_self else np.full(X.shape[0], -1)
        inside = simplex >= 0
        if inside.any():
            s = simplex[inside]
            T = self._tri.transform[s]
            b = np.einsum("nij,nj->ni", T[:, :-1, :], X[inside] - T[:, -1, :])
            bary = np.concatenate([b, 1.0 - b.sum(axis=1, keepdims=True)], axis=1)
            verts = self._tri.simplices[s]
            out[inside] = np.einsum("nv,nvr->nr", bary, self.phi_[verts])
        rest = np.flatnonzero(~inside)
        if rest.size:
            dist, ind = self._nn_vertices.kneighbors(X[rest], n_neighbors=2)
            j = ind[:, 1] if exclude_self else ind[:, 0]
            off = X[rest] - P[j]
            out[rest] = self.phi_[j] + np.einsum("nrd,nd->nr", self._grad_v[j], off)
        return out

    def _phi(self, X, exclude_self=False):
        if self._graph == "knn":
            return self._extend_knn(X, exclude_self)
        return self._extend_delaunay(X, exclude_self)

    def _fit_proba_scale(self, codes, labelled, loo=None):
        """Slope of the logistic map fitted on leave-one-out ``phi`` at the labelled samples."""
        phi = self._phi(self._X, exclude_self=True)[labelled] if loo is None else loo
        c = codes[labelled]
        if phi.shape[1] == 1:
            z = phi[:, 0] - 0.5
            sgn = np.where(c == 1, 1.0, -1.0)

            def loss(la):
                return np.logaddexp(0.0, -np.exp(la) * sgn * z).mean()
        else:

            def loss(la):
                s = np.exp(la) * phi
                s = s - s.max(axis=1, keepdims=True)
                return (np.log(np.exp(s).sum(axis=1)) - s[np.arange(s.shape[0]), c]).mean()

        res = minimize_scalar(loss, bounds=(-8.0, 8.0), method="bounded")
        return float(np.exp(res.x))

    # -- predict ------------------------------------------------------------------------------
    def _validate_predict(self, X):
        check_is_fitted(self)
        return validate_data(self, X, reset=False, dtype=np.float64)

    def decision_function(self, X):
        """Relaxed level-set function minus 1/2 at ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_classes)
            For two classes, positive means ``classes_[1]``; approximately the signed
            distance to the decision boundary in units of the mean neighbour distance.
            For more, one column per class (class versus the rest).
        """
        X = self._validate_predict(X)
        if self._constant is not None:
            n_cls = self.classes_.shape[0]
            if n_cls <= 2:
                return np.full(X.shape[0], 0.5 if self._constant == 1 else -0.5)
            out = np.full((X.shape[0], n_cls), -0.5)
            out[:, self._constant] = 0.5
            return out
        phi = self._phi(X) - 0.5
        return phi[:, 0] if phi.shape[1] == 1 else phi

    def predict(self, X):
        """Class labels of ``X``: the class with the largest ``phi``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples,)
        """
        d = self.decision_function(X)
        if self.classes_.shape[0] == 1:
            return np.full(d.shape[0], self.classes_[0])
        idx = (d > 0).astype(np.int64) if d.ndim == 1 else np.argmax(d, axis=1)
        return self.classes_[idx]

    def predict_proba(self, X):
        """Class probabilities: a logistic (softmax) map of ``phi``, same ranking.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples, n_classes)
        """
        d = self.decision_function(X)
        if self.classes_.shape[0] == 1:
            return np.ones((d.shape[0], 1))
        if d.ndim == 1:
            p1 = 0.5 * (1.0 + np.tanh(0.5 * self.proba_scale_ * d))
            return np.stack([1.0 - p1, p1], axis=1)
        s = self.proba_scale_ * d
        s = s - s.max(axis=1, keepdims=True)
        e = np.exp(s)
        return e / e.sum(axis=1, keepdims=True)

    def predict_log_proba(self, X):
        """Logarithm of :meth:`predict_proba`."""
        with np.errstate(divide="ignore"):
            return np.log(self.predict_proba(X))

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
