"""A global extension of the relaxed functions: ridge regression on Gaussian kernel features.

The neighbour extension (:mod:`ndboundary.domains.pointcloud_extension`) reads ``phi``
off the few training samples nearest to a new point. Where the samples are sparse for
their dimension (a few hundred in six to twenty dimensions), a point's neighbours lie
about as far from it as the class boundary does, and a density gradient pulls them to
one side: between classes nested by radius, the neighbours of an outer point are mostly
inner samples, and no local average recovers the boundary. A support vector machine
with a Gaussian kernel of width about the data's spread (scikit-learn's
``gamma="scale"``, ``1 / (n_features Var X)``) fits such boundaries, since its function
is smooth on the scale of the whole sample.

:class:`KernelExtension` is that kind of fit, made to ``phi``: kernel ridge regression
of the relaxed functions on the Gaussian kernel, in the Nyström features of
:data:`N_LANDMARKS` landmark samples (all of them on fewer samples) so that its cost
grows linearly with the number of samples, and a constant feature (:data:`BIAS`): far
from the samples, where every kernel vanishes, the fit tends to the value the data call
for (outside a ball of one class, the other class) rather than to the samples' mean.
The kernel's width and the ridge are chosen by the exact leave-one-out error of the
regression (the hat matrix of a ridge gives it in closed form, Allen 1974), among the
widths :data:`GAMMA_FACTORS` times scikit-learn's scale and the ridges :data:`RIDGES`.

With three classes or more, one regression per class against the rest must represent a
class whose region is a shell between two others by a function that rises and falls
again, which a smooth fit of a few hundred samples does poorly. The relaxed partition's
boundaries are pairwise, where two classes' functions tie, so
:class:`PairwiseKernelExtension` fits each difference ``phi_i - phi_j`` on the samples of
those two classes only (one boundary, as a support vector machine's one-versus-one
classifiers do), and gives class ``i`` the function ``1/2 + min_j (phi_i - phi_j) / 2``:
above 1/2 exactly where class ``i`` wins against every other. The pairs share one pool
of landmarks, :data:`N_LANDMARKS` split among the classes (at least
:data:`MIN_CLASS_LANDMARKS` each), and a pair's features come from its two classes'
landmarks: a new point's distances are computed once for every pair.
"""

from __future__ import annotations

import threading
from itertools import combinations, repeat

import numpy as np

from .._compiled import squared_distances
from .._threads import available_threads, in_blocks, shared_pool
from ..domains.pointcloud_extension import rows_of
from ..solvers.common import blas_threads

__all__ = [
    "BIAS",
    "BLAS_THREADED_SAMPLES",
    "GAMMA_FACTORS",
    "MIN_CLASS_LANDMARKS",
    "N_LANDMARKS",
    "RIDGES",
    "KernelExtension",
    "PairwiseKernelExtension",
    "kernel_basis",
    "kernel_extension",
]

#: Landmarks of the Nyström features: the kernel's rank is kept to this many.
N_LANDMARKS = 200

#: Landmarks of each class in the pool the pairs of classes share, at least (or all of
#: the class's samples, if fewer).
MIN_CLASS_LANDMARKS = 10

#: Kernel widths tried, as factors of ``1 / (n_features Var X)`` (scikit-learn's
#: ``gamma="scale"`` for the support vector machine): that width and wider ones.
GAMMA_FACTORS = (0.25, 0.5, 1.0)

#: Ridges tried, per sample (the ridge is ``n_samples`` times one of them).
RIDGES = tuple(np.logspace(-6.0, -1.0, 11).tolist())

#: The constant feature beside the kernel's: the kernel ``k + BIAS**2``, whose
#: constant part (ridged like the rest) lets the fit settle away from the samples'
#: mean far from the landmarks.
BIAS = 1.0

_CHUNK = 8192

#: Samples from which the fit's products run on every BLAS thread.
BLAS_THREADED_SAMPLES = 20000


def _blas_limit(n_samples):
    """BLAS threads for a fit to ``n_samples``: one below :data:`BLAS_THREADED_SAMPLES`,
    where the products (samples by landmarks) are small and OpenBLAS's threads spin on
    them and multiply the wall time on a machine with any other load (as in the solvers,
    :mod:`ndboundary.solvers.common`); no limit above, where two threads cut the time of
    a fit to 100 000 samples by a quarter to a half.
    """
    return 1 if n_samples < BLAS_THREADED_SAMPLES else None


def _gamma_scale(X):
    """scikit-learn's ``gamma="scale"``: ``1 / (n_features Var X)`` (1 for constant ``X``)."""
    var = float(X.var())
    return 1.0 / (X.shape[1] * var) if var > 0.0 else 1.0


def kernel_extension(X, phi, codes):
    """The kernel fit of ``phi`` (n_samples, n_functions) for samples of class ``codes``:
    a :class:`KernelExtension` for one function (two classes), else a
    :class:`PairwiseKernelExtension`.
    """
    return kernel_basis(X, codes, np.asarray(phi).reshape(X.shape[0], -1).shape[1]).fit(phi)


def kernel_basis(X, codes, n_functions):
    """All of :func:`kernel_extension` that comes before the functions: the samples'
    kernel features, their eigenbases and the hat matrices' diagonals, for every width,
    ridge and pair of classes. Its ``fit(phi)`` returns the extension of ``phi`` (of
    ``n_functions`` columns), as :func:`kernel_extension` does; the classifier builds it
    beside the relaxation, which needs one core while this needs the other. It holds, for
    each of the three widths, every sample's features: about ``n_samples * 201`` floats a
    width (0.5 GB in all at 100 000 samples), each sample once per pair it belongs to.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.kernel_extension import kernel_basis, kernel_extension
    >>> X = np.random.default_rng(0).normal(size=(300, 4))
    >>> codes = np.digitize(np.linalg.norm(X, axis=1), [1.5, 2.3])
    >>> basis = kernel_basis(X, codes, 3)
    >>> a, b = basis.fit(np.eye(3)[codes]), kernel_extension(X, np.eye(3)[codes], codes)
    >>> bool(np.array_equal(a(X[:5]), b(X[:5])))
    True
    """
    if n_functions == 1:
        return _SingleBasis(X)
    return _PairwiseBasis(X, codes, n_functions)


def _sq_dist(A, B):
    """Squared Euclidean distances between the rows of ``A`` and ``B``, clipped at 0."""
    d = (A * A).sum(axis=1)[:, None] + (B * B).sum(axis=1)[None, :] - 2.0 * (A @ B.T)
    return np.maximum(d, 0.0)


#: Rows whose distances to the landmarks are held at once while new points are evaluated:
#: one (rows, n_landmarks) buffer per block, filled again for each run of rows, small
#: enough to stay in cache and below the size that the allocator would map afresh.
_RUN = 128


def _rowwise(X, n_out, landmarks_t, values, transform=None):
    """``values(d, out)`` over the rows of ``X`` (of ``transform(X)`` where it is given,
    each block of rows transformed on its own), run by run: ``d`` the squared distances of
    a run of rows to the landmarks (given transposed, (n_features, n_landmarks)), which
    ``values`` may overwrite, and ``out`` the run's rows of the result, (n, n_out).

    Each row's distances are summed by the same loop whatever rows come with it
    (:func:`~ndboundary._compiled.squared_distances`, not a matrix product whose blocking
    depends on the number of rows), so that new points computed block by block equal
    those computed at once, to the bit. Blocks of rows run on several threads (numpy's
    loops release the GIL), each with one distance buffer of :data:`_RUN` rows.
    """
    X = np.asarray(X, dtype=np.float64)
    out = np.empty((X.shape[0], n_out))
    held = threading.local()

    def block(c):
        d = getattr(held, "d", None)  # the thread's buffer, for all its blocks
        if d is None:
            d = held.d = np.empty((_RUN, landmarks_t.shape[1]))
        points = rows_of(X, c, transform, held)
        for a in range(0, c.stop - c.start, _RUN):
            run = slice(a, min(c.stop - c.start, a + _RUN))
            dr = d[: run.stop - run.start]
            squared_distances(np.ascontiguousarray(points[run]), landmarks_t, dr)
            values(dr, out[c][run])

    for _ in in_blocks(X.shape[0], _CHUNK, block, first_alone=False):
        pass
    return out


def _kernels(d, gammas, in_place):
    """``exp(-gamma * d)`` for each of ``gammas`` in turn. A width twice the last one
    squares its kernel, ``exp(-2 g d) = exp(-g d)^2``: a product per entry instead of an
    exponential; ``in_place`` squares into the last kernel's array, which must be done with
    before the next one is asked for.
    """
    E = None
    for i, gamma in enumerate(gammas):
        if E is not None and gamma == 2.0 * gammas[i - 1]:
            E = np.multiply(E, E, out=E if in_place else None)
        else:
            E = np.exp(-gamma * d)
        yield E


def _width_basis(E, gamma, d_landmarks):
    """What the ridge fits on the kernel ``E = exp(-gamma d)`` (n, m) to the landmarks
    share whatever function they fit: ``(gamma, to_features, V, FV, shrink, one_minus_h)``.

    The features are ``F = [E T, BIAS]`` with ``T`` (``to_features``) the Nyström map of
    the landmarks' kernel; the ridge works in their eigenbasis, ``F^T F = V diag(s) V^T``,
    whose Gram matrix comes from ``E^T E`` and the column sums of ``E``. ``FV = F V``
    (n, p); ``shrink`` (ridges, p) divides the projections on ``FV`` for each ridge of
    :data:`RIDGES`; ``one_minus_h`` (n, ridges) is one minus the hat matrix's diagonal,
    which turns fits into exact leave-one-out values.
    """
    n = E.shape[0]
    ridges = np.asarray(RIDGES)
    s, U = np.linalg.eigh(np.exp(-gamma * d_landmarks))
    keep = s > 1e-10 * s.max()
    to_features = U[:, keep] / np.sqrt(s[keep])
    gram = np.empty((to_features.shape[1] + 1,) * 2)
    gram[:-1, :-1] = to_features.T @ (E.T @ E) @ to_features
    gram[-1, :-1] = gram[:-1, -1] = BIAS * (E.sum(axis=0) @ to_features)
    gram[-1, -1] = n * BIAS * BIAS
    s, V = np.linalg.eigh(gram)
    FV = E @ (to_features @ V[:-1])
    FV += BIAS * V[-1]
    shrink = 1.0 / (s[None, :] + ridges[:, None] * n)
    h = np.square(FV) @ shrink.T
    return gamma, to_features, V, FV, shrink, np.maximum(1.0 - h, 1e-12)


def _ridge_candidate(width, target):
    """The ridge fit of ``target`` (n, n_functions) on one width's features
    (:func:`_width_basis`), with the ridge of :data:`RIDGES` of least leave-one-out
    error: ``(error, gamma, ridge, to_features, V, coef, fit, loo)``. Every ridge is
    solved at once: coefficients (ridges, features, functions) and the fits, one
    product each.
    """
    gamma, to_features, V, FV, shrink, one_minus_h = width
    n = FV.shape[0]
    ridges = np.asarray(RIDGES)
    proj = FV.T @ target
    coefs = shrink[:, :, None] * proj[None]
    p, r = coefs.shape[1:]
    fit = (FV @ coefs.transpose(1, 0, 2).reshape(p, -1)).reshape(n, ridges.size, r).transpose(1, 0, 2)
    loo = target[None] - (target[None] - fit) / one_minus_h.T[:, :, None]
    err = ((loo - target[None]) ** 2).sum(axis=(1, 2))
    i = int(np.argmin(err))  # the first of equal errors, as RIDGES orders them
    return float(err[i]), gamma, float(ridges[i]), to_features, V, coefs[i], fit[i], loo[i]


class _RidgeBasis:
    """The features of ridge fits on a Gaussian kernel and a constant, for every width
    of :data:`GAMMA_FACTORS` (:func:`_width_basis`), before any function is fitted.

    ``d_rows`` (n, m) holds the squared distances of the fitted samples to the ``m``
    landmarks, ``d_landmarks`` (m, m) those among the landmarks.
    """

    def __init__(self, d_rows, d_landmarks, gamma_scale):
        # Below BLAS_THREADED_SAMPLES the widths are computed on several threads at once
        # (each product on one BLAS thread), above one at a time, each kernel squared in
        # place, with every BLAS thread.
        gammas = [gamma_scale * factor for factor in GAMMA_FACTORS]
        threaded = d_rows.shape[0] < BLAS_THREADED_SAMPLES and available_threads() > 1
        kernels = _kernels(d_rows, gammas, in_place=not threaded)
        if threaded:
            self.widths = list(shared_pool().map(_width_basis, list(kernels), gammas, repeat(d_landmarks)))
        else:  # each kernel done with before the next one overwrites it
            self.widths = [_width_basis(E, gamma, d_landmarks) for E, gamma in zip(kernels, gammas, strict=True)]


class _RidgeFit:
    """Ridge regression of ``phi`` on the Nyström features of a :class:`_RidgeBasis`,
    width and ridge chosen by exact leave-one-out error. The fit evaluates new points
    from their squared distances to the landmarks (:meth:`at`).
    """

    def __init__(self, basis, phi):
        mean = phi.mean(axis=0)
        target = phi - mean
        fits = [_ridge_candidate(width, target) for width in basis.widths]
        # the least error; the first of equal ones, as GAMMA_FACTORS and RIDGES order them
        _, self.gamma, self.ridge, to_features, V, coef, fit, loo = min(fits, key=lambda f: f[0])
        w = V @ coef
        self.weights = to_features @ w[:-1]  # (m, n_functions)
        self.offset = mean + BIAS * w[-1]
        self.fitted = fit + mean
        self.loo = loo + mean

    def at(self, d, out=None):
        """The fit at points of squared distances ``d`` (n, m) to the landmarks; with
        ``out`` (n, n_functions), written there, and ``d`` overwritten.
        """
        if out is None:
            return np.einsum("bl,lr->br", np.exp(-self.gamma * d), self.weights) + self.offset
        np.exp(np.multiply(d, -self.gamma, out=d), out=d)
        np.einsum("bl,lr->br", d, self.weights, out=out)
        out += self.offset
        return out


class _FittedAtSamples:
    """What the kernel fits share: their values at the training samples held out
    (``_loo``) and fitted (``fitted``), and a lean copy for new points only.
    """

    @classmethod
    def _on_basis(cls, basis, phi):
        """The fit of ``phi`` on the features ``basis`` (:func:`kernel_basis`)."""
        ext = object.__new__(cls)
        ext._fit_on(basis, phi)
        return ext

    def leave_one_out(self, rows):
        """The fit at the training samples ``rows``, each sample left out of the
        regressions that held it (exactly, for the width and ridge chosen): shape
        (len(rows), n_functions).
        """
        return self._loo[np.asarray(rows)]

    def for_queries(self):
        """A copy that evaluates new points only (no :meth:`leave_one_out` or ``fitted``)."""
        lean = object.__new__(type(self))
        lean.__dict__.update(self.__dict__, _loo=None, fitted=None)
        return lean


class KernelExtension(_FittedAtSamples):
    """Kernel ridge regression of vertex functions on a Gaussian kernel, evaluated at new points.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        The training samples (the classifier's scaled coordinates).
    phi : ndarray of shape (n_samples, n_functions)
        The functions at the samples (all of them, labelled or not: the width and the
        ridge are chosen by how well the regression predicts ``phi``, not the labels).

    Attributes
    ----------
    gamma : float
        The kernel's ``gamma`` (``exp(-gamma |x - y|^2)``), in the coordinates of ``X``.
    ridge : float
        The ridge chosen, per sample.
    fitted : ndarray of shape (n_samples, n_functions)
        The regression at the training samples.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.kernel_extension import KernelExtension
    >>> X = np.random.default_rng(0).normal(size=(200, 6))
    >>> phi = (np.linalg.norm(X, axis=1) > 2.3).astype(float)[:, None]  # an outer shell
    >>> ext = KernelExtension(X, phi)
    >>> bool(ext(np.zeros((1, 6)))[0, 0] < 0.5 < ext(np.full((1, 6), 1.5))[0, 0])
    True
    """

    def __init__(self, X, phi):
        self._fit_on(_SingleBasis(X), phi)

    def _fit_on(self, basis, phi):
        phi = np.asarray(phi, dtype=np.float64).reshape(basis.n_samples, -1)
        self._landmarks, self._landmarks_t = basis.landmarks, basis.landmarks_t
        with blas_threads(_blas_limit(basis.n_samples)):
            fit = _RidgeFit(basis.ridge, phi)
        self.gamma, self.ridge, self.fitted, self._loo = fit.gamma, fit.ridge, fit.fitted, fit.loo
        fit.fitted = fit.loo = None
        self._fit = fit

    def __call__(self, X, transform=None):
        """The fitted functions at the points ``X`` (n, n_features), or at ``transform(X)``
        (each block of rows transformed on its own): shape (n, n_functions).

        Each row is computed by the same sums whatever rows come with it, so predictions
        made block by block equal those made at once, to the bit; blocks of rows are
        evaluated on several threads (:func:`~ndboundary._threads.in_blocks`).
        """
        return _rowwise(X, self._fit.weights.shape[1], self._landmarks_t, self._fit.at, transform)


class PairwiseKernelExtension(_FittedAtSamples):
    """Kernel fits of the differences of per-class functions, one per pair of classes.

    Pair ``(i, j)`` fits ``phi_i - phi_j`` on the samples of classes ``i`` and ``j`` only,
    as :class:`KernelExtension` does, on its two classes' landmarks of a shared pool and
    at the width scale of all the samples. Class ``i``'s function is
    ``1/2 + min_j g_ij / 2`` over the pairs' fits ``g_ij`` (``g_ji = -g_ij``), which is
    about ``phi_i`` inside the classes' regions, and is above 1/2 exactly where class
    ``i`` wins each of its pairs.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        The training samples.
    phi : ndarray of shape (n_samples, n_classes)
        One function per class (``n_classes >= 2``).
    codes : ndarray of shape (n_samples,)
        Each sample's class, in ``range(n_classes)``, every class with a sample; a pair is
        fitted on its two classes' samples.

    Attributes
    ----------
    pairs : list of tuple
        The pairs ``(i, j)``, ``i < j``, in the order of the fits.
    fitted : ndarray of shape (n_samples, n_classes)
        The class functions at the training samples, each pair's fit in-sample.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.kernel_extension import PairwiseKernelExtension
    >>> X = np.random.default_rng(0).normal(size=(300, 4))
    >>> codes = np.digitize(np.linalg.norm(X, axis=1), [1.5, 2.3])  # ball, shell, outside
    >>> ext = PairwiseKernelExtension(X, np.eye(3)[codes], codes)
    >>> ext(np.array([[0.0, 0, 0, 0], [1.9, 0, 0, 0], [3.5, 0, 0, 0]])).argmax(axis=1)
    array([0, 1, 2])
    """

    def __init__(self, X, phi, codes):
        phi = np.asarray(phi, dtype=np.float64).reshape(np.shape(X)[0], -1)
        self._fit_on(_PairwiseBasis(X, codes, phi.shape[1]), phi)

    def _fit_on(self, basis, phi):
        phi = np.asarray(phi, dtype=np.float64).reshape(basis.d.shape[0], -1)
        self.n_classes, self.pairs = basis.n_classes, basis.pairs
        self._landmarks, self._landmarks_t = basis.landmarks, basis.landmarks_t
        self._columns, self._fits = [], []
        fit = np.full((phi.shape[0], self.n_classes), np.inf)  # min_j g_ij, pair by pair
        loo = fit.copy()
        with blas_threads(_blas_limit(phi.shape[0])):
            for (i, j), rows, cols, ridge in zip(basis.pairs, basis.rows, basis.columns, basis.ridges, strict=True):
                pair = _RidgeFit(ridge, phi[rows, i : i + 1] - phi[rows, j : j + 1])
                g = (np.exp(-pair.gamma * basis.d[:, cols]) @ pair.weights + pair.offset)[:, 0]
                g_loo = g.copy()
                g[rows], g_loo[rows] = pair.fitted[:, 0], pair.loo[:, 0]
                self._worst(fit, i, j, g)
                self._worst(loo, i, j, g_loo)
                pair.fitted = pair.loo = None
                self._columns.append(cols)
                self._fits.append(pair)
        self.fitted = 0.5 + 0.5 * fit
        self._loo = 0.5 + 0.5 * loo

    @staticmethod
    def _worst(worst, i, j, g):
        """Fold pair ``(i, j)``'s values ``g = g_ij`` into ``worst``, the least ``g_kl`` of
        each class ``k`` so far (``g_ji = -g_ij``): one pair at a time, so that no
        (n, n_pairs) array is held with many classes.
        """
        np.minimum(worst[:, i], g, out=worst[:, i])
        np.minimum(worst[:, j], -g, out=worst[:, j])

    def __call__(self, X, transform=None):
        """The class functions at the points ``X`` (n, n_features), or at ``transform(X)``:
        shape (n, n_classes).

        Each row is computed by the same sums whatever rows come with it, as in
        :class:`KernelExtension`.
        """

        def classes(d, worst):
            worst.fill(np.inf)
            for (i, j), cols, pair in zip(self.pairs, self._columns, self._fits, strict=True):
                self._worst(worst, i, j, pair.at(d[:, cols])[:, 0])
            worst *= 0.5
            worst += 0.5

        return _rowwise(X, self.n_classes, self._landmarks_t, classes, transform)


class _SingleBasis:
    """:func:`kernel_basis` for one function: the landmarks and one :class:`_RidgeBasis`."""

    def __init__(self, X):
        X = np.asarray(X, dtype=np.float64)
        n = self.n_samples = X.shape[0]
        pick = np.random.default_rng(0).permutation(n)[:N_LANDMARKS] if n > N_LANDMARKS else np.arange(n)
        self.landmarks = X[np.sort(pick)]
        self.landmarks_t = np.ascontiguousarray(self.landmarks.T)
        with blas_threads(_blas_limit(n)):
            self.ridge = _RidgeBasis(
                _sq_dist(X, self.landmarks), _sq_dist(self.landmarks, self.landmarks), _gamma_scale(X)
            )

    def fit(self, phi):
        """The :class:`KernelExtension` of ``phi`` (n_samples, 1)."""
        return KernelExtension._on_basis(self, phi)


class _PairwiseBasis:
    """:func:`kernel_basis` for one function per class: the shared pool of landmarks and
    a :class:`_RidgeBasis` per pair of classes, on the pair's samples (``rows``) and
    landmarks (``columns``).
    """

    def __init__(self, X, codes, n_classes):
        X = np.asarray(X, dtype=np.float64)
        codes = np.asarray(codes).reshape(-1)
        self.n_classes = n_classes
        counts = np.bincount(codes, minlength=n_classes)
        if counts.shape[0] != n_classes or not counts.all():
            raise ValueError(f"codes must hold every class of range({n_classes}) at least once")
        self.pairs = list(combinations(range(n_classes), 2))
        share = max(N_LANDMARKS // n_classes, MIN_CLASS_LANDMARKS)
        order = np.random.default_rng(0).permutation(X.shape[0])
        pool = np.sort(np.concatenate([order[codes[order] == c][:share] for c in range(n_classes)]))
        self.landmarks = X[pool]
        self.landmarks_t = np.ascontiguousarray(self.landmarks.T)
        pool_codes = codes[pool]
        gamma = _gamma_scale(X)
        self.rows, self.columns, self.ridges = [], [], []
        with blas_threads(_blas_limit(X.shape[0])):
            self.d = d = _sq_dist(X, self.landmarks)
            for i, j in self.pairs:
                rows = np.flatnonzero((codes == i) | (codes == j))
                cols = np.flatnonzero((pool_codes == i) | (pool_codes == j))
                self.ridges.append(_RidgeBasis(d[np.ix_(rows, cols)], d[np.ix_(pool[cols], cols)], gamma))
                self.rows.append(rows)
                self.columns.append(cols)

    def fit(self, phi):
        """The :class:`PairwiseKernelExtension` of ``phi`` (n_samples, n_classes)."""
        return PairwiseKernelExtension._on_basis(self, phi)
