"""Pictures of planar partitions into many regions: the relaxed cells in their region's colour,
the interfaces between regions and the junctions where three or more meet
(:func:`plot_partition`), beside the jagged input partition (:func:`figure_partition`).

Both are re-exported by :mod:`ndboundary.plot`. matplotlib is imported when a function here is
called, not when ndboundary is imported.
"""

from __future__ import annotations

import numpy as np

from .plot_common import edge_segments, element_faces, finish_figure, pyplot

__all__ = ["plot_partition", "figure_partition"]


def _check_planar(domain):
    """Partitions are drawn flat: 2-D points with triangles or polygons."""
    if domain.points.shape[1] != 2 or domain.element_dim != 2:
        raise ValueError(
            "drawing a partition needs a planar domain (2-D points, triangles or polygons), got "
            f"{domain.element_dim}-D elements on {domain.points.shape[1]}-D points"
        )


def _region_colours(n_regions, cmap=None):
    """One RGBA colour per region, shape (n_regions, 4): a qualitative colormap's colours in
    order (tab10 up to ten regions, tab20 up to twenty, repeating beyond), or ``cmap`` sampled
    evenly when it is a continuous one. Lightened so that black interfaces stand out.
    """
    from matplotlib.colors import ListedColormap

    plt = pyplot()
    cm = plt.get_cmap(cmap if cmap is not None else ("tab10" if n_regions <= 10 else "tab20"))
    if isinstance(cm, ListedColormap) and cm.N < 256:
        rgba = cm(np.arange(n_regions) % cm.N)
    else:
        rgba = cm(np.linspace(0.0, 1.0, n_regions))
    rgba[:, :3] = 0.8 * rgba[:, :3] + 0.2
    return rgba


def _label_regions(labels, classes, n_elements):
    """The index into ``classes`` of every element label."""
    labels = np.asarray(labels)
    if labels.ndim != 1 or labels.shape[0] != n_elements:
        raise ValueError(f"labels must hold one label per element ({n_elements}), got an array of shape {labels.shape}")
    classes = np.asarray(classes)
    idx = np.minimum(np.searchsorted(classes, labels), classes.size - 1)
    bad = classes[idx] != labels
    if bad.any():
        raise ValueError(f"labels hold {labels[bad][0]!r}, which is not one of the result's classes")
    return idx


def _jagged_interfaces(domain, regions, n_regions):
    """The edges between elements of different regions, (n, 2) vertex pairs, each once."""
    edges = [domain.interface_facets(regions == r) for r in range(n_regions)]
    edges = [np.sort(e, axis=1) for e in edges if e is not None and len(e)]
    if not edges:
        return np.zeros((0, 2), dtype=np.int64)
    return np.unique(np.concatenate(edges), axis=0)


def _finish_planar(ax, points):
    lo, hi = points.min(axis=0), points.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def _plot_labels(domain, regions, colours, ax):
    """The jagged partition: elements in their region's colour, the edges between regions in black."""
    from matplotlib.collections import LineCollection, PolyCollection

    pts = domain.points
    faces = element_faces(domain)
    # flat like the relaxed panel, so the two differ by their interfaces only
    elements = PolyCollection(
        [pts[f] for f in faces], facecolors=colours[regions], edgecolors="none", antialiased=False
    )
    elements.set_gid("elements")
    ax.add_collection(elements)
    edges = _jagged_interfaces(domain, regions, colours.shape[0])
    if len(edges):
        jagged = LineCollection(edge_segments(pts, edges), colors="k", linewidths=1.0)
        jagged.set_gid("interfaces")
        ax.add_collection(jagged)
    _finish_planar(ax, pts)
    return ax


def plot_partition(result, *, ax=None, cmap=None, junctions=True, colours=None):
    """Draw the relaxed partition of a planar domain: its cells in their region's colour, the
    interfaces between regions in black and, with ``junctions``, a white dot where three or
    more regions meet.

    The cells are those of ``result.partition()``, the exact partition by the largest region
    function, so the colours follow the relaxed interfaces rather than the elements.

    Parameters
    ----------
    result : RegionsResult or RelaxResult
        What :func:`~ndboundary.relax` returned on a planar domain (two regions too).
    ax : matplotlib Axes, optional
    cmap : str or Colormap, optional
        Region ``r`` gets the colormap's colour ``r`` (default tab10, tab20 beyond ten regions).
    junctions : bool, default True
        Mark the junctions (``result.interfaces().junctions()``), one marker each.
    colours : ndarray of shape (n_regions, 4), optional
        RGBA colour per region, overriding ``cmap``.

    Returns
    -------
    matplotlib Axes
        The cells, interfaces and junctions are the collections with gid ``"cells"``,
        ``"interfaces"`` and ``"junctions"``.

    Raises
    ------
    ValueError
        When the domain is not planar (a surface in 3-D, a solid, a curve).

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.plot import plot_partition
    >>> mesh = kuhn_grid(16, 2)
    >>> c = mesh.element_centroids()
    >>> labels = np.where(c[:, 0] < 0, 0, np.where(c[:, 1] < 0, 1, 2))  # a T of three regions
    >>> ax = plot_partition(relax(mesh, labels, on="elements"))
    >>> [coll.get_gid() for coll in ax.collections]; plt.close(ax.figure)
    ['cells', 'interfaces', 'junctions']
    """
    dom = result.domain
    _check_planar(dom)
    plt = pyplot()
    from matplotlib.collections import LineCollection, PolyCollection

    part = result.partition()
    if colours is None:
        colours = _region_colours(part.n_regions, cmap)
    if ax is None:
        ax = plt.figure(figsize=(5, 5)).add_subplot(111)
    cells = part.cells
    # drawn without antialiasing: antialiased edges would leave seams between the many small cells
    filled = PolyCollection(
        cells.points[cells.simplices], facecolors=colours[cells.regions], edgecolors="none", antialiased=False
    )
    filled.set_gid("cells")
    ax.add_collection(filled)
    faces = result.interfaces()
    if len(faces):
        lines = LineCollection(edge_segments(faces.points, faces.simplices), colors="k", linewidths=1.4)
        lines.set_gid("interfaces")
        ax.add_collection(lines)
    if junctions:
        j = faces.junctions()
        where = j.points[j.simplices[:, 0]] if len(j) else np.zeros((0, 2))
        dots = ax.scatter(where[:, 0], where[:, 1], s=36, c="white", edgecolors="k", linewidths=1.2, zorder=5)
        dots.set_gid("junctions")
    _finish_planar(ax, dom.points)
    return ax


def figure_partition(result, labels, *, title=None, zoom=None, cmap=None):
    """The jagged input partition beside the relaxed one, for a planar domain.

    Left: the elements in the colour of their label, with the jagged interfaces (edges between
    elements of different labels). Right: the relaxed partition (:func:`plot_partition`), its
    interfaces and its junctions marked. A region has the same colour in both panels.

    Parameters
    ----------
    result : RegionsResult or RelaxResult
        What :func:`~ndboundary.relax` returned for ``labels`` (two or more regions).
    labels : array-like of shape (n_elements,)
        The element labels given to :func:`~ndboundary.relax`; each one of ``result.classes``.
    title : str, optional
    zoom : (xmin, xmax, ymin, ymax), optional
        Limits for both panels.
    cmap : str or Colormap, optional
        See :func:`plot_partition`.

    Returns
    -------
    matplotlib Figure

    Raises
    ------
    ValueError
        When the domain is not planar, or ``labels`` are not one of ``result.classes`` per element.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.plot import figure_partition
    >>> mesh = kuhn_grid(16, 2)
    >>> c = mesh.element_centroids()
    >>> labels = np.where(c[:, 0] < 0, 0, np.where(c[:, 1] < 0, 1, 2))
    >>> fig = figure_partition(relax(mesh, labels, on="elements"), labels)
    >>> [ax.get_title() for ax in fig.axes]; plt.close(fig)
    ['jagged partition (labels)', 'relaxed partition (1 junction)']
    """
    dom = result.domain
    _check_planar(dom)
    plt = pyplot()
    regions = _label_regions(labels, result.classes, dom.n_elements)
    colours = _region_colours(len(result.classes), cmap)
    fig, axes = plt.subplots(1, 2, figsize=(10, 5.2))
    _plot_labels(dom, regions, colours, axes[0])
    plot_partition(result, ax=axes[1], colours=colours)
    n = len(result.interfaces().junctions())
    names = ("jagged partition (labels)", f"relaxed partition ({n} junction{'' if n == 1 else 's'})")
    return finish_figure(fig, axes, names, zoom, title)
