"""Helpers shared by :mod:`ndboundary.plot` and :mod:`ndboundary.plot_regions`: the lazy
matplotlib import, the element polygons of a domain and line segments of vertex pairs.

matplotlib is imported by :func:`pyplot` when it is called, not when this module is imported.
"""

from __future__ import annotations

import numpy as np

__all__ = ["pyplot", "element_faces", "edge_segments", "finish_figure"]


def pyplot():
    """``matplotlib.pyplot``, imported now; an ImportError saying how to install it otherwise."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("ndboundary.plot needs matplotlib: pip install 'ndboundary[plot]'") from exc
    return plt


def element_faces(domain):
    """Element polygons as lists of vertex indices (triangles for a simplicial complex).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.plot_common import element_faces
    >>> faces = element_faces(kuhn_grid(2, 2))
    >>> len(faces), len(faces[0])
    (8, 3)
    """
    polys = getattr(domain, "polygons", None)
    if polys is not None:
        return [np.asarray(p) for p in polys]
    simplices = getattr(domain, "simplices", None)
    if simplices is None or simplices.shape[1] != 3:
        raise ValueError("plotting needs a domain of triangles or polygons")
    return list(simplices)


def edge_segments(points, simplices):
    """The segments between the first two vertices of each row of ``simplices``, shape (n, 2, dim).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.plot_common import edge_segments
    >>> edge_segments(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), [[0, 1], [1, 2]]).tolist()
    [[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 1.0]]]
    """
    return points[np.asarray(simplices)[:, :2]]


def finish_figure(fig, axes, names, zoom=None, title=None):
    """Title each of ``axes`` with ``names``, limit them to ``zoom`` ``(x0, x1, y0, y1)``
    if given, title the figure, lay it out; returns ``fig``.
    """
    for ax, name in zip(axes, names, strict=True):
        ax.set_title(name)
        if zoom is not None:
            ax.set_xlim(zoom[0], zoom[1])
            ax.set_ylim(zoom[2], zoom[3])
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
