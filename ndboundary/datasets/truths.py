"""Smooth truths: signed functions of points, negative inside, and labellings made from them."""

from __future__ import annotations

import numpy as np

__all__ = ["ball", "circle", "flower", "flower_curve", "label_by", "torus"]


def circle(x, r=0.6):
    """Signed distance to the circle of radius ``r`` about the origin (first two coordinates).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import circle
    >>> circle(np.array([[0.0, 0.0], [1.0, 0.0]])).round(6).tolist()
    [-0.6, 0.4]
    """
    return np.linalg.norm(x[:, :2], axis=1) - r


def flower(x, r=0.55, amplitude=0.2, lobes=5):
    """Signed radial offset from the flower ``r (1 + amplitude cos(lobes theta))``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import flower
    >>> flower(np.array([[0.66, 0.0], [0.0, 0.0]])).round(6).tolist()  # on a lobe's tip; the centre
    [0.0, -0.66]
    """
    th = np.arctan2(x[:, 1], x[:, 0])
    return np.linalg.norm(x[:, :2], axis=1) - r * (1 + amplitude * np.cos(lobes * th))


def flower_curve(n=20000, r=0.55, amplitude=0.2, lobes=5):
    """Points densely sampled on the :func:`flower` curve, shape (n, 2), in order.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import flower, flower_curve
    >>> curve = flower_curve(1000)
    >>> curve.shape, bool(np.abs(flower(curve)).max() < 1e-12)
    ((1000, 2), True)
    """
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    rad = r * (1 + amplitude * np.cos(lobes * th))
    return np.stack([rad * np.cos(th), rad * np.sin(th)], axis=1)


def ball(x, r=0.6):
    """Signed distance to the sphere of radius ``r`` about the origin, any dimension.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import ball
    >>> ball(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])).round(6).tolist()
    [-0.6, 0.4]
    """
    return np.linalg.norm(x, axis=1) - r


def torus(x, R=0.55, r=0.25):
    """Signed distance to the torus of radii ``R``, ``r`` around the z axis.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import torus
    >>> torus(np.array([[0.55, 0.0, 0.0], [0.0, 0.0, 0.0]])).round(6).tolist()  # core circle; centre
    [-0.25, 0.3]
    """
    q = np.linalg.norm(x[:, :2], axis=1) - R
    return np.hypot(q, x[:, 2]) - r


def label_by(domain, truth, *, on="elements"):
    """Label each element (by its centroid) or vertex: 1 inside ``truth < 0``, else 0.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> mesh = kuhn_grid(10, 2)
    >>> labels = label_by(mesh, circle)
    >>> labels.shape, int(labels.sum()), int(label_by(mesh, circle, on="vertices").sum())
    ((200,), 60, 25)
    """
    x = domain.element_centroids() if on == "elements" else domain.points
    return (truth(x) < 0).astype(np.int64)
