"""The band of a label image, found on its index grid: :func:`image_band`.

On a pixel or voxel grid the band of :mod:`ndboundary.pipeline.band` needs no mesh: zeta
is made of the faces between pixels of different labels, and the graph distance along
the grid's edges is a weighted L1 distance, which separates over the axes (two sweeps
per axis, each a minimum with the neighbour's distance plus one step). The band, cut as
a :class:`~ndboundary.domains.image.GridBand`, is then relaxed as the band of the whole
grid would be, without the whole grid ever being built: the cost of a large image
follows its boundaries, and its memory the band.
"""

from __future__ import annotations

from itertools import product

import numpy as np

__all__ = [
    "corner_distances",
    "corners_of",
    "grid_mean_edge_length",
    "image_band",
    "pixels_at",
    "region_band",
    "zeta_corners",
]


def zeta_corners(codes):
    """The corners of the faces between pixels of different labels: zeta's vertices.

    Parameters
    ----------
    codes : ndarray of shape ``shape``
        Each pixel's label (any type that compares).

    Returns
    -------
    ndarray of bool of shape ``shape + 1``
        Over the grid's corners (C order, as :class:`~ndboundary.ImageGrid` numbers them).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import zeta_corners
    >>> zeta_corners(np.array([[0, 1], [0, 1]])).astype(int).tolist()  # the middle column
    [[0, 1, 0], [0, 1, 0], [0, 1, 0]]
    """
    shape, dim = codes.shape, codes.ndim
    hot = np.zeros(tuple(n + 1 for n in shape), dtype=bool)
    for a in range(dim):
        # the face between pixels i and i + 1 along a
        differs = codes[(slice(None),) * a + (slice(1, None),)] != codes[(slice(None),) * a + (slice(None, -1),)]
        for offsets in product((0, 1), repeat=dim - 1):
            # its corners: plane i + 1 along a, pixel j and j + 1 along the other axes
            steps = iter(offsets)
            where = tuple(slice(1, n) if b == a else slice(o := next(steps), o + n) for b, n in enumerate(shape))
            hot[where] |= differs
    return hot


def corner_distances(sources, steps, limit):
    """The graph distance of every corner from the ``sources`` along the grid's edges.

    Parameters
    ----------
    sources : ndarray of bool
        Over the corners (any number of axes).
    steps : sequence of float
        The length of an edge along each axis (in the unit the distances are wanted in).
    limit : float
        Distances above it are set to ``inf`` (as the band's Dijkstra stops there).

    Returns
    -------
    ndarray of float64, the shape of ``sources``

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import corner_distances
    >>> hot = np.zeros((3, 4), dtype=bool); hot[0, 0] = True
    >>> corner_distances(hot, (1.0, 0.5), 2.0).tolist()
    [[0.0, 0.5, 1.0, 1.5], [1.0, 1.5, 2.0, inf], [2.0, inf, inf, inf]]
    """
    d = np.where(sources, 0.0, np.inf)
    for a, step in enumerate(steps):
        v = np.moveaxis(d, a, 0)  # a view: the sweeps write into d
        for i in range(1, v.shape[0]):
            np.minimum(v[i], v[i - 1] + step, out=v[i])
        for i in range(v.shape[0] - 2, -1, -1):
            np.minimum(v[i], v[i + 1] + step, out=v[i])
    d[d > limit] = np.inf
    return d


def grid_mean_edge_length(shape, spacing):
    """The mean length of a grid's edges (as :meth:`~ndboundary.Domain.mean_edge_length`
    measures it on the whole grid), from its shape.

    Examples
    --------
    >>> from ndboundary.pipeline.grid_band import grid_mean_edge_length
    >>> grid_mean_edge_length((1, 1), (1.0, 3.0))  # two edges of each length
    2.0
    """
    counts = [n * np.prod([m + 1 for b, m in enumerate(shape) if b != a]) for a, n in enumerate(shape)]
    return float(np.dot(counts, spacing) / np.sum(counts))


def image_band(codes, spacing, h, width):
    """The pixels of a label image within the band of half-width ``width`` around zeta.

    The pixels holding a corner within graph distance ``width * h`` of zeta's corners
    along the grid's edges: the elements :func:`~ndboundary.pipeline.band.band_elements`
    selects on the whole grid.

    Parameters
    ----------
    codes : ndarray
        The image's labels (any type that compares).
    spacing : sequence of float
        The distance between pixel centres along each axis.
    h : float
        The unit of ``width``: the whole grid's mean edge length.
    width : float

    Returns
    -------
    pixels : ndarray of int64
        The band's pixels, as increasing indices in C order.
    distance : ndarray of float64
        The graph distance (units of ``h``) from zeta of each corner of the band's pixels,
        ``inf`` beyond ``width``, in the order of the grid's corners (as a
        :class:`~ndboundary.domains.image.GridBand` numbers its vertices).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import image_band
    >>> codes = (np.arange(10) >= 5).astype(int).reshape(1, 10)  # one row: 0 0 0 0 0 1 1 1 1 1
    >>> pixels, distance = image_band(codes, (1.0, 1.0), 1.0, 1.0)
    >>> pixels.tolist(), distance.reshape(2, -1)[0].tolist()  # pixels touching corners 4 to 6
    ([3, 4, 5, 6], [inf, 1.0, 0.0, 1.0, inf])
    """
    hot = zeta_corners(codes)
    steps = [s / h for s in spacing]
    box = _reach_box(hot, steps, width)
    distances = corner_distances(hot[box], steps, width)
    local = pixels_at(distances <= width)
    return _image_pixels(local, box, codes.shape), distances[corners_of(local)]


def _reach_box(corners, steps, width):
    """The corners within graph distance ``width`` of any of ``corners`` lie in this box
    (a tuple of slices over the corners, one more each side, clipped to the grid): an L1
    path stays within the box of its ends. The band's search reads only the box, so that
    its cost follows zeta, not the image. The whole grid when no corner is set.
    """
    box = []
    for a, step in enumerate(steps):
        along = np.flatnonzero(corners.any(axis=tuple(b for b in range(corners.ndim) if b != a)))
        if along.size == 0:
            return (slice(None),) * corners.ndim
        reach = int(np.floor(width / step)) + 1
        box.append(slice(max(int(along[0]) - reach, 0), min(int(along[-1]) + reach + 1, corners.shape[a])))
    return tuple(box)


def _image_pixels(local, box, shape):
    """The pixels ``local`` (a boolean array over the pixels of the corners' ``box``) as
    increasing indices into the image of ``shape`` (C order: a box's pixels keep their
    order in the image).
    """
    starts = [b.start or 0 for b in box]
    return np.ravel_multi_index(tuple(i + s for i, s in zip(np.nonzero(local), starts, strict=True)), shape)


def pixels_at(corners):
    """Whether each pixel holds one of the ``corners`` (a boolean array over the grid's
    corners, shape ``shape + 1``), shape ``shape``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import pixels_at
    >>> pixels_at(np.array([[True, False, False], [False, False, False]])).tolist()
    [[True, False]]
    """
    shape = tuple(n - 1 for n in corners.shape)
    out = np.zeros(shape, dtype=bool)
    for corner in product((0, 1), repeat=corners.ndim):
        out |= corners[tuple(slice(c, c + n) for c, n in zip(corner, shape, strict=True))]
    return out


def corners_of(pixels):
    """Whether each corner belongs to one of the ``pixels`` (a boolean array, shape
    ``shape``), shape ``shape + 1``: the vertices of those pixels.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import corners_of
    >>> corners_of(np.array([[True, False]])).astype(int).tolist()
    [[1, 1, 0], [1, 1, 0]]
    """
    out = np.zeros(tuple(n + 1 for n in pixels.shape), dtype=bool)
    for corner in product((0, 1), repeat=pixels.ndim):
        out[tuple(slice(c, c + n) for c, n in zip(corner, pixels.shape, strict=True))] |= pixels
    return out


def region_band(codes, region, box, spacing, h, width):
    """The band of one region of a label image, found in a box around it.

    The pixels within the band of half-width ``width`` (units of ``h``) around the
    region's own zeta (the faces between its pixels and the others), as
    :func:`image_band` finds them for the image of the region against the rest, but
    reading only ``box``: the region's bounding box widened by the band's reach, in which
    every graph path of length up to ``width * h`` from the region's zeta lies (an
    L1 path stays within the box of its ends). The cost follows the region, not the image.

    Parameters
    ----------
    codes : ndarray of int
        Every pixel's region.
    region : int
    box : tuple of slice
        Holds the region's pixels and every pixel within ``width * h`` of them along each
        axis (clipped to the image).
    spacing : sequence of float
    h : float
    width : float

    Returns
    -------
    pixels : ndarray of int64
        The band's pixels, increasing indices into the image (C order).
    distance : ndarray of float64
        The graph distance (units of ``h``) from zeta of each corner of the band's pixels,
        in the order of the whole grid's corners (as a
        :class:`~ndboundary.domains.image.GridBand` numbers its vertices).
    labels : ndarray of bool
        Whether each of the band's pixels is the region's.
    codes : ndarray of int
        Each of the band's pixels' region.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.grid_band import image_band, region_band
    >>> codes = np.zeros((1, 12), dtype=int); codes[0, 5:7] = 1; codes[0, 7:] = 2
    >>> box = (slice(0, 1), slice(3, 9))
    >>> pixels, distance, labels, _ = region_band(codes, 1, box, (1.0, 1.0), 1.0, 1.0)
    >>> pixels.tolist(), labels.tolist()
    ([3, 4, 5, 6, 7, 8], [False, False, True, True, False, False])
    >>> pixels.tolist() == image_band(codes == 1, (1.0, 1.0), 1.0, 1.0)[0].tolist()
    True
    """
    sub = codes[box]
    mine = sub == region
    distances = corner_distances(zeta_corners(mine), [s / h for s in spacing], width)
    near = distances <= width
    local = pixels_at(near)
    return _image_pixels(local, box, codes.shape), distances[corners_of(local)], mine[local], sub[local]
