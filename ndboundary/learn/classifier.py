"""A classifier whose decision boundary is a relaxed level set over the training data.

:class:`LevelSetClassifier` builds one domain over the training samples (a kNN
:class:`~ndboundary.PointCloud`, or a :class:`~ndboundary.DelaunayComplex` in low
dimension), takes the class labels as vertex labels and relaxes each class's jagged
boundary against the rest into the level set ``phi = 1/2`` of a smooth function
(:func:`ndboundary.relax`). Since ``grad phi`` is close to unit length, ``phi - 1/2``
behaves like a signed distance (in units of the mean neighbour distance ``h``) to the
relaxed boundary: it is the decision function.

New points get ``phi`` from the fitted function alone, through the domain's
:meth:`~ndboundary.Domain.extension` (a continuous neighbour-weighted first-order
extension on a kNN graph, :mod:`ndboundary.domains.pointcloud_extension`; barycentric
interpolation on a Delaunay complex, :mod:`ndboundary.domains.delaunay`), on a kNN graph
mixed with a kernel ridge regression of ``phi`` over the whole sample (for three
classes or more, of the differences of the classes' functions, pair by pair:
:mod:`ndboundary.learn.kernel_extension`; weight chosen by held-out accuracy), so the
prediction of a point never depends on the other points predicted with it.

Three rules keep degenerate inputs classified as a user expects:

* the features are centred and divided by one power-of-two scale for all of them
  (:mod:`ndboundary.learn.scaling`): distances keep their ratios, so features of any
  magnitude float64 holds give the same predictions;
* the relaxed functions have regional maxima only at samples of their class and minima
  only at the others (:mod:`ndboundary.learn.extrema`): around a class smaller than a
  stencil the integration leaves peaks above 1/2 with no sample of the class in them;
* on fewer distinct samples than ``n_neighbors + 1`` the kNN graph is complete and
  ``lam`` is scaled by ``n_neighbors / (n_distinct - 1)``: a sample's measure in units
  of ``h`` goes as ``1 / k``, so it grows as the stencil shrinks, and the field term would
  otherwise outweigh the boundary term and carry the relaxed boundary past samples.
"""

from __future__ import annotations

import contextlib
import functools
import sys
import time

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from .._threads import Beside
from ..domains.pointcloud import PointCloud, distinct_rows
from ..domains.pointcloud_extension import predicted_codes
from ..solvers.common import blas_threads
from .band import classifier_band
from .extrema import relax_classes
from .graph import build_graph
from .kernel_extension import kernel_basis
from .params import check_classifier_params
from .poisson import poisson_labels
from .probability import logistic_slope, probabilities
from .propagation import vote
from .scaleout import landmark_samples, lazy_rows, transduce_the_rest
from .scaling import apply_scaling, fit_scaling

__all__ = ["LevelSetClassifier"]

#: How the classifier integrates the field (:mod:`ndboundary.pipeline.integration`): the
#: first-order fit ``||grad phi - X||^2 + lam ||S phi - 1/2||^2``. On a neighbour graph
#: most samples end a cut edge, so zeta's points are dense and the kinks this form puts
#: at them average out: over the ten sets of ``benchmarks/classify.py`` it classifies
#: as the squared Laplacian does (figures in the README), while its system is a
#: screened Laplacian that conjugate gradients with a diagonal preconditioner solve
#: (tens to a few hundred iterations). The squared Laplacian's needs a sparse factor, which on data of
#: high intrinsic dimension fills in to a dense matrix (minutes and gigabytes at 20 000
#: samples).
INTEGRATION_FORM = "gradient"

#: The weights ``w`` of the kernel ridge fit of ``phi`` (:mod:`ndboundary.learn.kernel_extension`)
#: in the decision function, ``(1 - w)`` times the neighbour extension plus ``w`` times
#: the kernel fit, that the classifier chooses from by held-out accuracy (the first on
#: equal accuracy). The even mix averages two estimates of ``phi`` at a new point that
#: err in different places (the neighbour extension where the samples are sparse for
#: their dimension, the kernel fit where the boundary is finer than its width), and the
#: kernel fit alone serves classes nested on the scale of the whole sample. The
#: neighbour extension alone is not a candidate: the choice between it and the mix
#: rests on a few held-out samples either way, and with it among the candidates the mean
#: accuracy of ``benchmarks/classify.py`` fell on three of its four runs (the ten sets and
#: ``--sets other``, each on two draws of folds), as it did with the weights 1/4 and 3/4
#: added.
KERNEL_WEIGHTS = (0.5, 1.0)


class LevelSetClassifier(ClassifierMixin, BaseEstimator):
    """Classify by the relaxed level sets of the class labels over a graph of the samples.

    Parameters
    ----------
    n_neighbors : int or "auto", default="auto"
        Neighbours per sample of the kNN graph. ``"auto"``: 40 up to 2 000 samples, 15
        beyond (:mod:`ndboundary.learn.graph`): on small noisy samples the wider stencil
        steadies the tangent gradients, on large ones the graph's cost grows with ``k``
        while 15 neighbours already hold the data's shape (``benchmarks/classify.py`` and
        ``benchmarks/scale.py`` measure both). The value used is ``n_neighbors_``.
    extension_neighbors : int, default=25
        Nearest training samples whose first-order extensions of ``phi`` are averaged
        at a new point (kNN graph only), with weights that fade to 0 at the next
        neighbour's distance: a continuous extension, whose decision boundary is smoother
        than that of a plain average over fewer neighbours.
    extension_power : float or "auto", default="auto"
        Power ``p`` of the factor ``(d_1 / d_j)^p`` of the extension weights (kNN graph
        only; ``d_j`` is the distance to neighbour ``j`` in units of its own local scale,
        :mod:`ndboundary.domains.pointcloud_extension`): 0 leaves the fading weights alone (smoothest),
        large values follow the nearest sample (sharpest; in high dimension the
        distances to the neighbours differ little, so sharp needs large powers).
        ``"auto"`` picks the power among :data:`EXTENSION_POWERS` whose extension best
        predicts each training sample's label from its neighbours (leave-one-out, no
        refit): noisy, overlapping classes pick 0 and sparse high-dimensional ones large
        powers. Only powers whose extension still gives every class at least one of its
        own samples compete (leave-one-out cannot see a class of one sample, and would
        smooth it away), and power 0 only on more distinct samples than
        ``extension_neighbors + 1`` (on fewer it would be a global average). The value
        used is ``extension_power_``.
    graph : {"knn", "delaunay", "auto"}, default="knn"
        Domain over the samples: a kNN :class:`~ndboundary.PointCloud`, a
        :class:`~ndboundary.DelaunayComplex` (2 to 6 features, distinct samples), or ``"auto"``: Delaunay
        for 2 or 3 features and distinct samples, kNN otherwise.
    lam : float, default=1.0
        Weight of the boundary term of the integration (see :func:`ndboundary.relax`):
        larger stays closer to the jagged kNN boundary, smaller relaxes further. Scaled
        up on a complete kNN graph (module docstring).
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
        be enclosed by their own level set; off by default, since voting also treats a
        diffuse minority class as noise.
    vote_threshold : float, default=2/3
        Share of the sample and its neighbours a label needs to overrule the sample's
        own label in a voting pass, in ``[0, 1]``. 0 is plurality voting (ties keep the
        label); a qualified majority leaves the labels of samples near a true class
        boundary alone and removes only labels that are isolated among another class.
    tol : float, default=1e-6
        Relative residual of the linear solves of the relaxation. Decisions do not move
        below about 1e-5, and each decade costs a few more iterations.
    unlabeled : int, float, str or None, default=None
        The label that marks an unlabelled sample (``-1`` to follow
        :class:`~sklearn.semi_supervised.LabelSpreading`). None: every label is a class.
    band : "auto", float or None, default="auto"
        Relax each class only over the samples within this graph distance of its jagged
        boundary, in units of ``h``, and fill ``phi`` beyond them with the signed graph
        distance (the ``band`` of :func:`ndboundary.relax`); None: the whole graph.
        ``"auto"``: a band of 16 ``h`` on a kNN graph of more than 20 000 samples, the
        whole graph otherwise (:func:`~ndboundary.learn.band.classifier_band`, which says
        where the band pays). The value used is ``band_``.
    intrinsic_dim : int or None, default=None
        Tangent dimension of the kNN operators; estimated when None.
    max_samples : int, float or None, default=None
        Build the graph over this many landmarks only (a count, or a share of the
        samples in ``(0, 1]``), drawn at random and stratified by label so that every
        class keeps its share and at least one sample; the other samples are predicted
        by the fitted extension (:mod:`ndboundary.learn.scaleout`). With it, ``fit``
        also takes a Dask array ``X`` and computes only the landmarks' rows. None: every
        sample.
    random_state : int, Generator or None, default=None
        Seed of the approximate neighbour search (used beyond 20 000 samples) and of the
        landmarks' draw.
    verbose : bool, default=False
        Print progress to stderr.

    Attributes
    ----------
    classes_ : ndarray of shape (n_classes,)
    n_neighbors_ : int
        Neighbours per sample of the kNN graph (0 for a Delaunay complex).
    extension_power_ : float or None
        Power of the extension weights (None for a Delaunay complex).
    band_ : float or None
        Width of the band the classes were relaxed over, in units of ``h`` (None: the
        whole graph).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Only when ``X`` has string column names.
    center_ : ndarray of shape (n_features_in_,)
        Per-feature median of the training samples.
    scale_ : float
        One scale for all features, a power of two (the median distance of the training
        samples to ``center_``, rounded down): the classifier works on
        ``(X - center_) / scale_``.
    domain_ : Domain
        The graph over the distinct training samples, in those coordinates.
    phi_ : ndarray of shape (n_samples, n_relaxations)
        The relaxed functions on the training samples: one column for two classes
        (``phi > 1/2`` means ``classes_[1]``), one per class otherwise; with regional
        maxima only at samples of the class, minima only at the others.
    transduction_ : ndarray of shape (n_samples,)
        The labels of the training samples, unlabelled ones filled in by
        Poisson learning before the relaxation (beyond the landmarks, by ``predict``).
    landmarks_ : ndarray of int or None
        The rows of ``X`` the graph was built over (``max_samples``); None: all of them.
        ``phi_`` and ``domain_`` hold these rows only.
    extension_ : NeighborExtension or SimplexExtension or None
        The evaluator of ``phi_`` at new points (in the coordinates of ``domain_``),
        given by the domain (:meth:`~ndboundary.Domain.extension`); None when one class
        was seen.
    kernel_extension_ : KernelExtension or PairwiseKernelExtension or None
        Kernel ridge regression of ``phi_`` on a Gaussian kernel of about the data's
        spread (:mod:`ndboundary.learn.kernel_extension`), a global estimate of ``phi``
        at new points; for three classes or more, one fit of ``phi_i - phi_j`` per pair
        of classes on their samples, combined into one function per class. None where
        it has weight 0.
    kernel_weight_ : float
        Its weight in the decision function, ``(1 - w)`` times ``extension_`` plus ``w``
        times ``kernel_extension_``: one of :data:`KERNEL_WEIGHTS`, the one whose mix
        predicts the most labelled samples right held out, or 0 (the domain's extension
        alone) on a Delaunay complex and on too few samples to hold one out.
    proba_scale_ : float
        Slope of the logistic map from ``phi`` to probabilities, fitted on held-out
        estimates of ``phi`` at the labelled samples.

    Notes
    -----
    ``predict``, ``predict_proba`` and ``decision_function`` given a Dask array return
    one, computed block by block of rows; a row's prediction never depends on the rows
    predicted with it, so the blocks equal the in-memory result. dask-ml's
    ``ParallelPostFit`` wraps the classifier as it does any other.

    Semi-supervised use follows :class:`sklearn.semi_supervised.LabelSpreading`:
    with ``unlabeled=-1``, samples with ``y == -1`` are unlabelled (opt-in, so that
    ``-1`` stays an ordinary class label by default). They join the graph, and their labels are
    first given by Poisson learning from the labelled ones (:mod:`ndboundary.learn.poisson`:
    with few labels it keeps every class where the harmonic extension,
    :func:`~ndboundary.learn.harmonic_labels`, fades), then the relaxation runs on all
    samples.

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
        band="auto",
        intrinsic_dim=None,
        max_samples=None,
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
        self.band = band
        self.intrinsic_dim = intrinsic_dim
        self.max_samples = max_samples
        self.random_state = random_state
        self.verbose = verbose

    # -- helpers -------------------------------------------------------------------------
    def _log(self, msg, t0):
        if self.verbose:
            print(f"[LevelSetClassifier] {msg} ({time.perf_counter() - t0:.2f} s)", file=sys.stderr, flush=True)

    # -- fit -------------------------------------------------------------------------------
    def fit(self, X, y):
        """Build the graph over ``X`` and relax every class's boundary.

        Parameters
        ----------
        X : array-like or Dask array of shape (n_samples, n_features)
            A Dask array needs ``max_samples``: only the landmarks' rows are computed.
        y : array-like of shape (n_samples,)
            Class labels; the value ``unlabeled`` (if set) marks an unlabelled sample.

        Returns
        -------
        self : LevelSetClassifier
        """
        check_classifier_params(self)
        X_all, y_all, X, y, self.landmarks_ = landmark_samples(self, X, y)
        self._fit_rows(X, y)
        if self.landmarks_ is not None:
            self.transduction_ = transduce_the_rest(self, X_all, y_all)
        return self

    def _fit_rows(self, X, y):
        """The fit on the validated samples the graph is built over."""
        self.center_, self.scale_ = fit_scaling(X)
        X = apply_scaling(X, self.center_, self.scale_)
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
        n_distinct = distinct_rows(X)[0].shape[0]
        if n_cls == 1 or n_distinct < 2:
            self._constant = int(np.argmax(np.bincount(codes[labelled], minlength=n_cls)))
            self.transduction_ = self.classes_[np.where(labelled, codes, self._constant)]
            self.phi_ = np.zeros((X.shape[0], 1 if n_cls <= 2 else n_cls))
            self.proba_scale_, self.n_neighbors_ = 1.0, 0
            self.domain_ = self.extension_ = self.extension_power_ = self.band_ = self.kernel_extension_ = None
            self.kernel_weight_ = 0.0
            return
        self._constant = None
        self.domain_, self.n_neighbors_, lam = build_graph(
            X,
            self.graph,
            self.n_neighbors,
            self.lam,
            distinct=n_distinct == X.shape[0],
            intrinsic_dim=self.intrinsic_dim,
            random_state=self.random_state,
            # the extension's neighbours and the next one, from the graph's search
            search_neighbors=self.extension_neighbors + 1,
        )
        self.band_ = classifier_band(self.band, self.domain_)
        self._log(f"built the graph over {X.shape[0]} samples: {self.domain_!r}", t0)
        if not labelled.all():
            codes = poisson_labels(self.domain_, codes, labelled)
            self._log("Poisson learning of the labels", t0)
        self.transduction_ = self.classes_[codes]
        votes = codes
        if self.vote:
            votes = vote(self.domain_.vertex_neighborhoods(), codes, n_cls, self.vote, self.vote_threshold)
        # The kernel fit's features are computed on the second core while the relaxation,
        # mostly on one, runs; BLAS on one thread meanwhile, as this thread sets it: OpenBLAS
        # takes a raised thread count from the thread that lowered it only, so the limit
        # is set and lifted here, around the other thread's whole work.
        beside = isinstance(self.domain_, PointCloud) and self.domain_.n_unique > self.extension_neighbors + 1
        with blas_threads(1 if beside else None):
            basis = Beside(kernel_basis, X, codes, 1 if n_cls == 2 else n_cls) if beside else None
            with basis or contextlib.nullcontext():
                self.phi_ = relax_classes(
                    self.domain_, votes, n_cls, lam=lam, smoothing=self.smoothing, rtol=self.tol, band=self.band_,
                    form=INTEGRATION_FORM,
                )  # fmt: skip
            basis = None if basis is None else basis.result()
        self._log(f"relaxed {n_cls} classes", t0)
        self.extension_ = self.domain_.extension(
            self.phi_, n_neighbors=self.extension_neighbors, power=self.extension_power, labels=codes, labelled=labelled
        )
        self.extension_power_ = self.extension_.power
        self._log(f"extension power {self.extension_power_}", t0)
        held_out = self._fit_kernel_extension(basis, codes, labelled)
        self._log(f"kernel weight {self.kernel_weight_}", t0)
        self.proba_scale_ = logistic_slope(held_out, codes[labelled])
        self._log("fitted", t0)

    def _fit_kernel_extension(self, basis, codes, labelled):
        """Choose the weight of the kernel fit of ``phi`` (on the features ``basis`` of
        :func:`~ndboundary.learn.kernel_extension.kernel_basis`, or None where the domain's
        extension is kept alone) in the decision function.

        The weight of :data:`KERNEL_WEIGHTS` whose mix of the two extensions labels the
        most labelled samples right held out (the neighbour extension's
        :meth:`~ndboundary.domains.pointcloud_extension.NeighborExtension.held_out`, the
        kernel fit's exact leave-one-out) wins, among those that keep every class at one
        of its own samples. On a Delaunay complex, or on no more distinct samples than
        ``extension_neighbors + 1`` (too few to hold one out), or when no weight keeps
        every class, the domain's extension alone is kept (weight 0).

        Returns the held-out ``phi`` of the mix at the labelled samples, which the
        probabilities' slope is fitted on.
        """
        rows = np.flatnonzero(labelled)
        self.kernel_extension_, self.kernel_weight_ = None, 0.0
        if basis is None:
            return self.extension_.leave_one_out(rows)
        local = self.extension_.held_out(rows)
        kernel = basis.fit(self.phi_)
        kernel_loo = kernel.leave_one_out(rows)
        own_local, own_kernel = self.extension_.at_samples(rows), kernel.fitted[rows]
        lab = codes[rows]
        best = None
        for w in KERNEL_WEIGHTS:
            kept = predicted_codes((1.0 - w) * own_local + w * own_kernel)
            if not np.isin(np.unique(lab), lab[kept == lab]).all():
                continue
            right = int((predicted_codes((1.0 - w) * local + w * kernel_loo) == lab).sum())
            if best is None or right > best[0]:
                best = (right, w)
        if best is None:
            return local
        self.kernel_weight_ = best[1]
        self.kernel_extension_ = kernel
        return (1.0 - self.kernel_weight_) * local + self.kernel_weight_ * kernel_loo

    # -- predict ------------------------------------------------------------------------------
    def _validate_predict(self, X):
        """``X`` validated, and the map of its rows to the scaled coordinates the classifier
        was fitted in (:func:`~ndboundary.learn.scaling.apply_scaling`), which the extensions
        apply to each block of rows they read: a scaled copy of the whole of ``X`` would be
        memory made afresh at every call. A row that would overflow raises the scaling's
        ``ValueError`` as its block is read.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return X, functools.partial(apply_scaling, center=self.center_, scale=self.scale_)

    def decision_function(self, X):
        """Relaxed level-set function minus 1/2 at ``X``.

        Parameters
        ----------
        X : array-like or Dask array of shape (n_samples, n_features)

        Returns
        -------
        ndarray (a Dask array for a Dask ``X``) of shape (n_samples,) or (n_samples, n_classes)
            For two classes, positive means ``classes_[1]``; approximately the signed
            distance to the decision boundary in units of the mean neighbour distance.
            For more, one column per class (class versus the rest).
        """
        if (lazy := lazy_rows(self, "decision_function", X)) is not None:
            return lazy
        X, transform = self._validate_predict(X)
        if self._constant is not None:
            transform(X)  # the same error for rows too far as a fitted classifier raises
            n_cls = self.classes_.shape[0]
            if n_cls <= 2:
                return np.full(X.shape[0], 0.5 if self._constant == 1 else -0.5)
            out = np.full((X.shape[0], n_cls), -0.5)
            out[:, self._constant] = 0.5
            return out
        phi = self.extension_(X, transform)  # a fresh array, combined in place
        if self.kernel_weight_ > 0.0:
            kernel = self.kernel_extension_(X, transform)
            kernel *= self.kernel_weight_
            phi *= 1.0 - self.kernel_weight_
            phi += kernel
        phi -= 0.5
        return phi[:, 0] if phi.shape[1] == 1 else phi

    def predict(self, X):
        """Class labels of ``X``: the class with the largest ``phi``.

        Parameters
        ----------
        X : array-like or Dask array of shape (n_samples, n_features)

        Returns
        -------
        ndarray (a Dask array for a Dask ``X``) of shape (n_samples,)
        """
        if (lazy := lazy_rows(self, "predict", X)) is not None:
            return lazy
        d = self.decision_function(X)
        if self.classes_.shape[0] == 1:
            return np.full(d.shape[0], self.classes_[0])
        idx = (d > 0).astype(np.int64) if d.ndim == 1 else np.argmax(d, axis=1)
        return self.classes_[idx]

    def predict_proba(self, X):
        """Class probabilities: a logistic (softmax) map of ``phi``, same ranking.

        Parameters
        ----------
        X : array-like or Dask array of shape (n_samples, n_features)

        Returns
        -------
        ndarray (a Dask array for a Dask ``X``) of shape (n_samples, n_classes)
        """
        if (lazy := lazy_rows(self, "predict_proba", X)) is not None:
            return lazy
        d = self.decision_function(X)
        if self.classes_.shape[0] == 1:
            return np.ones((d.shape[0], 1))
        return probabilities(d, self.proba_scale_)

    def predict_log_proba(self, X):
        """Logarithm of :meth:`predict_proba`."""
        if (lazy := lazy_rows(self, "predict_log_proba", X)) is not None:
            return lazy
        with np.errstate(divide="ignore"):
            return np.log(self.predict_proba(X))

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
