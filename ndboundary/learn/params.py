"""Validation of the parameters of :class:`~ndboundary.LevelSetClassifier`.

Errors name the parameter and quote the value received, as scikit-learn's estimators do;
they are raised by ``fit``, never by ``__init__`` (scikit-learn's estimator contract).
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = ["check_classifier_params"]


def _is_int(value):
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_classifier_params(est):
    """Raise ``ValueError`` or ``TypeError`` on a bad parameter of the classifier ``est``.

    Parameters
    ----------
    est : LevelSetClassifier

    Examples
    --------
    >>> from ndboundary import LevelSetClassifier
    >>> from ndboundary.learn.params import check_classifier_params
    >>> check_classifier_params(LevelSetClassifier())
    >>> check_classifier_params(LevelSetClassifier(tol=0.0))
    Traceback (most recent call last):
    ...
    ValueError: tol must be in (0, 1), got 0.0
    """
    k = est.n_neighbors
    if isinstance(k, str):
        if k != "auto":
            raise ValueError(f"n_neighbors must be an integer or 'auto', got {k!r}")
    elif not _is_int(k):
        raise TypeError(f"n_neighbors must be an integer or 'auto', got {type(k).__name__}")
    elif k < 2:
        raise ValueError(f"n_neighbors must be >= 2, got {k}")
    p = est.extension_power
    if isinstance(p, str):
        if p != "auto":
            raise ValueError(f"extension_power must be a number or 'auto', got {p!r}")
    elif not _is_real(p):
        raise TypeError(f"extension_power must be a number or 'auto', got {type(p).__name__}")
    elif not 0.0 <= p < np.inf:
        raise ValueError(f"extension_power must be finite and >= 0, got {p}")
    q = est.extension_neighbors
    if not _is_int(q):
        raise TypeError(f"extension_neighbors must be an integer, got {type(q).__name__}")
    if q < 1:
        raise ValueError(f"extension_neighbors must be >= 1, got {q}")
    v = est.vote_threshold
    if not _is_real(v):
        raise TypeError(f"vote_threshold must be a number, got {type(v).__name__}")
    if not 0.0 <= v <= 1.0:
        raise ValueError(f"vote_threshold must be in [0, 1], got {v}")
    if not _is_real(est.tol):
        raise TypeError(f"tol must be a number, got {type(est.tol).__name__}")
    if not 0.0 < est.tol < 1.0:
        raise ValueError(f"tol must be in (0, 1), got {est.tol}")
    b = est.band
    if isinstance(b, str):
        if b != "auto":
            raise ValueError(f"band must be 'auto', a width in units of h or None, got {b!r}")
    elif b is not None:
        if not _is_real(b):
            raise TypeError(f"band must be 'auto', a number or None, got {type(b).__name__}")
        if not 0.0 < b < np.inf:
            raise ValueError(f"band must be a positive finite width in units of h, got {b}")
    m = est.max_samples
    if m is not None:
        if _is_int(m):
            if m < 2:
                raise ValueError(f"max_samples must be an integer >= 2, a share in (0, 1] or None, got {m}")
        elif _is_real(m):
            if not 0.0 < m <= 1.0:
                raise ValueError(f"max_samples must be an integer >= 2, a share in (0, 1] or None, got {m}")
        else:
            raise TypeError(f"max_samples must be an integer, a number or None, got {type(m).__name__}")
    if est.graph not in ("knn", "delaunay", "auto"):
        raise ValueError(f"graph must be 'knn', 'delaunay' or 'auto', got {est.graph!r}")
