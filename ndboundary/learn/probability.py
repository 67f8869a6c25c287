"""Class probabilities from relaxed level-set functions: the slope of a logistic map.

``phi - 1/2`` behaves like a signed distance to the relaxed boundary in units of ``h``;
the classifier turns it into probabilities with a logistic map (two classes) or a
softmax (more), ``p = sigma(s (phi - 1/2))``. The slope ``s`` is fitted by maximum
likelihood on leave-one-out estimates of ``phi`` at the training samples, so that a
sample does not vouch for itself.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["logistic_slope", "probabilities"]


def logistic_slope(phi, codes):
    """The slope of the logistic (softmax) map from ``phi`` to class probabilities that
    maximises the likelihood of the ``codes``.

    Parameters
    ----------
    phi : ndarray of shape (n_samples, n_functions)
        One column (two classes: ``phi > 1/2`` for class 1) or one per class.
    codes : ndarray of int of shape (n_samples,)
        The class of each sample (column index; 0 or 1 for one column).

    Returns
    -------
    float
        The slope, searched in ``[e^-8, e^8]``.

    Examples
    --------
    Values that separate the classes by a margin of 1 with a few errors:

    >>> import numpy as np
    >>> from ndboundary.learn.probability import logistic_slope
    >>> codes = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    >>> phi = 0.5 + np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0, -1.0])[:, None]
    >>> round(logistic_slope(phi, codes), 3)  # sigma(s) = 3/4: s = log 3
    1.099
    """
    if phi.shape[1] == 1:
        z = phi[:, 0] - 0.5
        sgn = np.where(codes == 1, 1.0, -1.0)

        def loss(la):
            return np.logaddexp(0.0, -np.exp(la) * sgn * z).mean()
    else:

        def loss(la):
            s = np.exp(la) * phi
            s = s - s.max(axis=1, keepdims=True)
            return (np.log(np.exp(s).sum(axis=1)) - s[np.arange(s.shape[0]), codes]).mean()

    res = minimize_scalar(loss, bounds=(-8.0, 8.0), method="bounded")
    return float(np.exp(res.x))


def probabilities(d, slope):
    """Class probabilities from decisions ``d = phi - 1/2``: a logistic map for one column
    (shape (n,)), a softmax over the columns otherwise; shape (n, n_classes).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.probability import probabilities
    >>> probabilities(np.array([0.0, np.log(3.0)]), 1.0).round(3).tolist()
    [[0.5, 0.5], [0.25, 0.75]]
    """
    if d.ndim == 1:
        p1 = 0.5 * (1.0 + np.tanh(0.5 * slope * d))
        return np.stack([1.0 - p1, p1], axis=1)
    s = slope * d
    s = s - s.max(axis=1, keepdims=True)
    e = np.exp(s)
    return e / e.sum(axis=1, keepdims=True)
