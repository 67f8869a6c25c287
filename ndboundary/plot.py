"""Pictures of 2-D domains and triangle surfaces: labels, phi, the jagged and relaxed boundaries,
and planar partitions into many regions with their interfaces and junctions (drawn by
:mod:`ndboundary.plot_regions`, whose functions are re-exported here).

matplotlib is imported when a function here is called, not when ndboundary is imported.
"""

from __future__ import annotations

import numpy as np

from .plot_common import edge_segments, element_faces, finish_figure, pyplot
from .plot_regions import figure_partition, plot_partition

__all__ = ["plot_domain", "plot_relaxation", "figure_relaxation", "plot_partition", "figure_partition"]


def _check_drawable(domain):
    if domain.dim not in (2, 3):
        raise ValueError(f"plotting needs 2-D points or a surface in 3-D, got {domain.dim}-D points")


def plot_domain(
    domain, *, labels=None, phi=None, level_set=None, boundary=None, ax=None, cmap="coolwarm", edgecolor=(0, 0, 0, 0.08)
):
    """Draw a 2-D domain or a surface with per-element labels or per-vertex ``phi``, and boundaries.

    Parameters
    ----------
    domain : Domain
        Triangles or polygons, in the plane or on a surface in 3-D.
    labels : array-like of shape (n_elements,), optional
        Drawn as two flat colours.
    phi : array-like of shape (n_vertices,), optional
        Drawn as a colour per element (the mean over its vertices).
    level_set : LevelSet, optional
        Drawn in red.
    boundary : ndarray of int of shape (n, 2), optional
        Jagged boundary edges (vertex pairs), drawn in black.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.plot import plot_domain
    >>> mesh = kuhn_grid(8, 2)
    >>> labels = label_by(mesh, circle)
    >>> ax = plot_domain(mesh, labels=labels, boundary=mesh.interface_facets(labels == 1))
    >>> len(ax.collections); plt.close(ax.figure)  # the elements and the jagged boundary
    2
    """
    _check_drawable(domain)
    plt = pyplot()
    from matplotlib.collections import LineCollection, PolyCollection

    faces = element_faces(domain)
    pts = domain.points
    if ax is None:
        fig = plt.figure(figsize=(5, 5))
        ax = fig.add_subplot(111, projection="3d" if domain.dim == 3 else None)
    if labels is not None:
        values = (np.asarray(labels) == np.unique(labels)[-1]).astype(float) * 0.6 + 0.2
    elif phi is not None:
        phi = np.asarray(phi, dtype=float)
        values = np.array([phi[f].mean() for f in faces])
    else:
        values = np.full(len(faces), 0.5)
    if domain.dim == 2:
        coll = PolyCollection([pts[f] for f in faces], array=values, cmap=cmap, edgecolors=edgecolor, linewidths=0.3)
        if labels is not None:
            coll.set_clim(0, 1)
        ax.add_collection(coll)
        if boundary is not None and len(boundary):
            ax.add_collection(LineCollection(edge_segments(pts, boundary), colors="k", linewidths=1.0))
        if level_set is not None and level_set.n_simplices:
            ax.add_collection(
                LineCollection(edge_segments(level_set.points, level_set.simplices), colors="red", linewidths=1.6)
            )
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xticks([])
        ax.set_yticks([])
    else:
        from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

        cm = plt.get_cmap(cmap)
        lo, hi = (0.0, 1.0) if labels is not None else (values.min(), values.max() + 1e-12)
        coll = Poly3DCollection(
            [pts[f] for f in faces], facecolors=cm((values - lo) / (hi - lo)), edgecolors=edgecolor, linewidths=0.1
        )
        ax.computed_zorder = False  # boundaries drawn over the surface
        ax.add_collection3d(coll)
        if boundary is not None and len(boundary):
            ax.add_collection3d(Line3DCollection(edge_segments(pts, boundary), colors="k", linewidths=1.0, zorder=5))
        if level_set is not None and level_set.n_simplices:
            ax.add_collection3d(
                Line3DCollection(
                    edge_segments(level_set.points, level_set.simplices), colors="red", linewidths=1.6, zorder=6
                )
            )
        lo3, hi3 = pts.min(axis=0), pts.max(axis=0)
        ax.set_xlim(lo3[0], hi3[0])
        ax.set_ylim(lo3[1], hi3[1])
        ax.set_zlim(lo3[2], hi3[2])
        ax.set_box_aspect(hi3 - lo3)
        ax.set_axis_off()
    return ax


def plot_relaxation(result, *, ax=None, value=0.5):
    """Draw ``phi`` with the jagged boundary (black) and its relaxation ``phi = value`` (red).

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.plot import plot_relaxation
    >>> mesh = kuhn_grid(8, 2)
    >>> ax = plot_relaxation(relax(mesh, label_by(mesh, circle), on="elements"))
    >>> len(ax.collections); plt.close(ax.figure)  # phi, the jagged and the relaxed boundary
    3
    """
    facets = result.boundary.facets
    return plot_domain(
        result.domain,
        phi=result.phi,
        level_set=result.level_set(value),
        boundary=facets if facets is not None and facets.shape[1] == 2 else None,
        ax=ax,
    )


def figure_relaxation(result, labels, *, title=None, zoom=None):
    """The paper's Fig. 1: labels with the jagged boundary, phi, and the relaxed boundary.

    Parameters
    ----------
    result : RelaxResult
    labels : array-like of shape (n_elements,)
    title : str, optional
    zoom : (xmin, xmax, ymin, ymax), optional
        Limits for 2-D panels.

    Returns
    -------
    matplotlib Figure

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.plot import figure_relaxation
    >>> mesh = kuhn_grid(8, 2)
    >>> labels = label_by(mesh, circle)
    >>> fig = figure_relaxation(relax(mesh, labels, on="elements"), labels, title="disc")
    >>> [ax.get_title() for ax in fig.axes]; plt.close(fig)
    ['jagged boundary', 'phi', 'relaxed boundary (phi = 1/2)']
    """
    plt = pyplot()
    dom = result.domain
    _check_drawable(dom)
    kw = {"projection": "3d"} if dom.dim == 3 else {}
    fig = plt.figure(figsize=(12, 4.3))
    axes = [fig.add_subplot(1, 3, i + 1, **kw) for i in range(3)]
    facets = result.boundary.facets
    edges = facets if facets is not None and facets.shape[1] == 2 else None
    ls = result.level_set()
    plot_domain(dom, labels=labels, boundary=edges, ax=axes[0])
    plot_domain(dom, phi=result.phi, ax=axes[1], cmap="viridis")
    plot_domain(dom, labels=labels, boundary=edges, level_set=ls, ax=axes[2], edgecolor=(0, 0, 0, 0.04))
    names = ("jagged boundary", "phi", "relaxed boundary (phi = 1/2)")
    return finish_figure(fig, axes, names, zoom if dom.dim == 2 else None, title)
