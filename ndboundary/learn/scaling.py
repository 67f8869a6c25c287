"""One global scale for the features: the classifier's coordinates of order one.

The relaxation and the extension only see ratios of distances, so a translated or
uniformly scaled copy of the data classifies the same; floating point does not. Squared
distances of features near ``1e200`` overflow, near ``1e-200`` they underflow to 0, and
the tangent frames, measures and weights built from them break down. The classifier
therefore works on ``(X - center) / scale``: ``center`` is the per-feature median and
``scale`` a single number for all features (the median distance of the samples to the
center), so that distances keep their ratios and the geometry is unchanged.

``scale`` is rounded to a power of two, so that dividing by it is exact: the
coordinates the classifier sees from ``X * 2**e`` are bit for bit those from ``X``, and
from ``X * s`` they differ from those of ``X`` by the rounding of ``X * s`` alone.
"""

from __future__ import annotations

import numpy as np

__all__ = ["apply_scaling", "fit_scaling"]

# The exponents of the powers of two a float64 holds (subnormal ones included).
_MIN_EXP, _MAX_EXP = -1074, 1023
# The least exponent of a normal float64.
_MIN_NORMAL_EXP = -1022


def _exponent(value):
    """``e`` with ``2**(e - 1) <= value < 2**e`` for a positive finite ``value``."""
    return int(np.frexp(value)[1])


def _row_norms(Z):
    """Euclidean norms of the rows of ``Z`` without overflow or underflow of the squares."""
    m = np.max(np.abs(Z), axis=1)
    safe = np.where(m > 0, m, 1.0)
    return m * np.sqrt(np.sum((Z / safe[:, None]) ** 2, axis=1))


def fit_scaling(X):
    """The center and the global scale of ``X``: ``(center, scale)``.

    ``center`` is the per-feature median; ``scale`` is the power of two nearest below the
    median distance of the rows to ``center`` (the largest distance if more than half the
    rows sit on the center; 1 if all do). Both are computed on ``X`` first divided by a
    power of two of its largest magnitude, so nothing overflows or underflows on the way.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Finite.

    Returns
    -------
    center : ndarray of shape (n_features,)
    scale : float
        A power of two.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.scaling import apply_scaling, fit_scaling
    >>> X = np.random.default_rng(0).normal(size=(100, 2))
    >>> c1, s1 = fit_scaling(X)
    >>> c2, s2 = fit_scaling(X * 2.0**600)
    >>> s2 / s1 == 2.0**600, bool(np.array_equal(apply_scaling(X, c1, s1), apply_scaling(X * 2.0**600, c2, s2)))
    (True, True)
    """
    X = np.asarray(X, dtype=np.float64)
    big = float(np.max(np.abs(X))) if X.size else 0.0
    if big == 0.0:
        return np.zeros(X.shape[1]), 1.0
    e0 = _exponent(big)
    X0 = np.ldexp(X, -e0)  # |X0| < 1, exact but for magnitudes below 2**-1074 of the largest
    c0 = np.median(X0, axis=0)
    r = _row_norms(X0 - c0)
    typical = float(np.median(r))
    if typical == 0.0:
        typical = float(r.max())
    e = e0 + (_exponent(typical) - 1 if typical > 0.0 else 0)
    e = min(max(e, _MIN_EXP), _MAX_EXP)
    return np.ldexp(c0, e0), float(np.ldexp(1.0, e))


def apply_scaling(X, center, scale, out=None):
    """``(X - center) / scale``, computed without intermediate overflow; a new array, or
    ``out``.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
    center : ndarray of shape (n_features,)
    scale : float
        A power of two, as :func:`fit_scaling` returns it.
    out : ndarray of shape (n_samples, n_features), optional
        Where to write the result (``X`` itself allowed).

    Returns
    -------
    ndarray of shape (n_samples, n_features)

    Raises
    ------
    ValueError
        If a coordinate is not finite after the scaling: ``X`` lies too far from the
        training data, relative to its spread, for float64 to hold.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.scaling import apply_scaling
    >>> apply_scaling(np.array([[3.0, 5.0]]), np.array([1.0, 1.0]), 2.0).tolist()
    [[1.0, 2.0]]
    >>> A = np.array([[3.0, 5.0]])
    >>> apply_scaling(A, np.array([1.0, 1.0]), 2.0, out=A) is A, A.tolist()
    (True, [[1.0, 2.0]])
    >>> apply_scaling(np.array([[1e300, 0.0]]), np.zeros(2), 2.0**-100)
    Traceback (most recent call last):
    ...
    ValueError: X lies too far from the training data for its scale (2^-100): scaled, it overflows float64
    """
    e = _exponent(scale) - 1
    X = np.asarray(X, dtype=np.float64)
    center = np.asarray(center, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        if _MIN_NORMAL_EXP <= -e <= _MAX_EXP:
            # a product by a normal power of two rounds as ldexp does, many times faster
            factor = np.ldexp(1.0, -e)
            Z = np.multiply(X, factor, out=out)
            Z -= center * factor
        else:
            Z = np.subtract(np.ldexp(X, -e), np.ldexp(center, -e), out=out)
        # a sum of finite values is finite unless it overflows: then each is checked
        finite = np.isfinite(Z.sum()) or np.isfinite(Z).all()
    if not finite:
        raise ValueError(f"X lies too far from the training data for its scale (2^{e}): scaled, it overflows float64")
    return Z
