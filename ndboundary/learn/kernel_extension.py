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
grows linearly with the number of samples. The kernel's width and the ridge are chosen
by the exact leave-one-out error of the regression (the hat matrix of a ridge gives it
in closed form, Allen 1974), among the widths :data:`GAMMA_FACTORS` times
scikit-learn's scale and the ridges :data:`RIDGES`.
"""

from __future__ import annotations

import numpy as np

from ..solvers.common import blas_threads

__all__ = ["GAMMA_FACTORS", "N_LANDMARKS", "RIDGES", "KernelExtension"]

#: Landmarks of the Nyström features: the kernel's rank is kept to this many.
N_LANDMARKS = 200

#: Kernel widths tried, as factors of ``1 / (n_features Var X)`` (scikit-learn's
#: ``gamma="scale"`` for the support vector machine): that width and wider ones.
GAMMA_FACTORS = (0.25, 0.5, 1.0)

#: Ridges tried, per sample (the ridge is ``n_samples`` times one of them).
RIDGES = tuple(np.logspace(-6.0, -1.0, 11).tolist())

_CHUNK = 8192


def _sq_dist(A, B):
    """Squared Euclidean distances between the rows of ``A`` and ``B``, clipped at 0."""
    d = (A * A).sum(axis=1)[:, None] + (B * B).sum(axis=1)[None, :] - 2.0 * (A @ B.T)
    return np.maximum(d, 0.0)


class KernelExtension:
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
        # one BLAS thread: the products are small (samples by landmarks), and OpenBLAS's
        # threads spin on them and multiply the wall time on a machine with any other load
        # (as in the solvers, :mod:`ndboundary.solvers.common`)
        with blas_threads(1):
            self._fit(np.asarray(X, dtype=np.float64), phi)

    def _fit(self, X, phi):
        """Choose the width and the ridge by leave-one-out error, and fit."""
        phi = np.asarray(phi, dtype=np.float64).reshape(X.shape[0], -1)
        n = X.shape[0]
        var = float(X.var())
        gamma0 = 1.0 / (X.shape[1] * var) if var > 0.0 else 1.0
        pick = np.random.default_rng(0).permutation(n)[:N_LANDMARKS] if n > N_LANDMARKS else np.arange(n)
        self._landmarks = X[np.sort(pick)]
        self._mean = phi.mean(axis=0)
        target = phi - self._mean
        best = None
        for factor in GAMMA_FACTORS:
            gamma = gamma0 * factor
            features, to_features = self._features(X, gamma)
            # ridge in the features' eigenbasis: F^T F = V diag(s) V^T
            s, V = np.linalg.eigh(features.T @ features)
            FV = features @ V
            del features
            proj = FV.T @ target
            lev = FV**2
            for ridge in RIDGES:
                shrink = 1.0 / (s + ridge * n)
                fit = FV @ (shrink[:, None] * proj)
                h = lev @ shrink
                loo = target - (target - fit) / np.maximum(1.0 - h, 1e-12)[:, None]
                err = float(((loo - target) ** 2).sum())
                if best is None or err < best[0]:
                    best = (err, gamma, ridge, to_features, V, shrink[:, None] * proj, fit, loo)
        _, self.gamma, self.ridge, to_features, V, coef, fit, loo = best
        self._loo = loo + self._mean
        self.fitted = fit + self._mean
        self._weights = to_features @ (V @ coef)  # (n_landmarks, n_functions)
        self._landmark_sq = np.einsum("ld,ld->l", self._landmarks, self._landmarks)

    def _features(self, X, gamma):
        """Nyström features of ``X`` for the kernel of ``gamma``: ``(features, map)``, the map
        taking kernel rows against the landmarks to features (``K_nm U diag(s)^-1/2``).
        """
        s, U = np.linalg.eigh(np.exp(-gamma * _sq_dist(self._landmarks, self._landmarks)))
        keep = s > 1e-10 * s.max()
        to_features = U[:, keep] / np.sqrt(s[keep])
        return np.exp(-gamma * _sq_dist(X, self._landmarks)) @ to_features, to_features

    def __call__(self, X):
        """The fitted functions at the points ``X`` (n, n_features): shape (n, n_functions).

        Each row is computed by the same sums whatever rows come with it (``einsum``'s
        own loops, not a matrix product whose blocking depends on the number of rows),
        so predictions made block by block equal those made at once, to the bit.
        """
        X = np.asarray(X, dtype=np.float64)
        out = np.empty((X.shape[0], self._weights.shape[1]))
        for a in range(0, X.shape[0], _CHUNK):
            c = slice(a, min(X.shape[0], a + _CHUNK))
            x = X[c]
            cross = np.einsum("bd,ld->bl", x, self._landmarks)
            d = np.einsum("bd,bd->b", x, x)[:, None] + self._landmark_sq[None, :] - 2.0 * cross
            out[c] = np.einsum("bl,lr->br", np.exp(-self.gamma * np.maximum(d, 0.0)), self._weights) + self._mean
        return out

    def leave_one_out(self, rows):
        """The regression at the training samples ``rows``, each fitted without its own
        sample (exactly, for the width and ridge chosen): shape (len(rows), n_functions).
        """
        return self._loo[np.asarray(rows)]

    def for_queries(self):
        """A copy that evaluates new points only (no :meth:`leave_one_out` or ``fitted``)."""
        lean = object.__new__(type(self))
        lean.__dict__.update(self.__dict__, _loo=None, fitted=None)
        return lean
