"""Pixel and voxel grids: :class:`ImageGrid`, the domain of a label image or volume.

A label image of shape ``(n0, n1)`` or volume of shape ``(n0, n1, n2)`` has one element
per pixel or voxel, in C order (the last index fastest, as ``labels.ravel()`` lists
them), each centred at ``origin + index * spacing``: the NIfTI / ITK and scikit-image
convention, so that what is relaxed lies where the scanner put it. The grid's vertices
are the pixels' corners, half a spacing from the centres. Pixels are quadrilaterals of a
:class:`~ndboundary.PolygonMesh`, voxels hexahedra of a
:class:`~ndboundary.PolyhedralMesh`: every operator, padding and band of those meshes
serves the grids unchanged, with anisotropic spacing. A voxel grid's faces, operators and
geometry come from its structure (:mod:`~ndboundary.domains.voxels`) instead of a search
and a computation per cell; the faces, and their geometry, are found only when read.
Cut to some of its pixels (a band), a grid stays a grid: a :class:`GridBand`, built from
their indices.
"""

from __future__ import annotations

import numbers
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from .._arrays import ragged_next, unique_values, used_vertices
from .._compiled_mesh import corner_max, corner_means
from .polygon import PolygonMesh
from .queries import as_mask
from .polyhedral import PolyhedralMesh
from .cell_operators import check_laplacian_options
from .voxels import (
    CORNER_BITS,
    _corners_of,
    box_constants,
    corner_strides,
    voxel_adjacency,
    voxel_edges,
    voxel_faces,
    voxel_refinement,
    voxel_gradient,
    voxel_stiffness,
)

__all__ = ["GridBand", "ImageGrid", "PixelBand", "PixelGrid", "VoxelBand", "VoxelGrid", "grid_facets"]


def grid_geometry(shape, spacing, origin):
    """``(shape, spacing, origin)`` checked, as tuples of one int / float per axis."""
    try:
        sizes = tuple(shape)
    except TypeError:
        raise TypeError(f"shape must be a sequence of integers, got {shape!r}") from None
    if not all(isinstance(n, numbers.Integral) and not isinstance(n, bool) for n in sizes):
        raise TypeError(f"shape must be a sequence of integers, got {shape!r}")
    shape = tuple(int(n) for n in sizes)
    dim = len(shape)
    if dim not in (2, 3):
        raise ValueError(f"an image grid is 2-D or 3-D, got shape {shape}")
    if min(shape) < 1:
        raise ValueError(f"shape must hold positive sizes, got {shape}")
    out = []
    for name, value in (("spacing", spacing), ("origin", origin)):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be one number or one per axis ({dim}), got {value!r}") from None
        arr = np.full(dim, float(arr)) if arr.ndim == 0 else arr
        if arr.shape != (dim,):
            raise ValueError(f"{name} must be one number or one per axis ({dim}), got {value!r}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite, got {value!r}")
        out.append(tuple(float(v) for v in arr))
    if min(out[0]) <= 0:
        raise ValueError(f"spacing must be positive, got {spacing!r}")
    return shape, out[0], out[1]


def grid_direction(direction, dim):
    """``direction`` checked: None, or a ``dim x dim`` orthonormal matrix (columns: the axes)."""
    if direction is None:
        return None
    d = np.asarray(direction, dtype=np.float64)
    if d.shape != (dim, dim) or not np.all(np.isfinite(d)):
        raise ValueError(f"direction must be a finite {dim} x {dim} matrix, got shape {d.shape}")
    if not np.allclose(d.T @ d, np.eye(dim), atol=1e-6):
        raise ValueError("direction must be orthonormal (a rotation, or a rotation and a reflection); a shear is not")
    return d


def corner_points(shape, spacing, origin, direction=None, corners=None):
    """The positions of the pixels' corners ``corners`` (indices in C order over ``shape + 1``;
    all of them by default), half a spacing below and above the pixel centres.
    """
    ticks = [spacing[a] * (np.arange(n + 1) - 0.5) for a, n in enumerate(shape)]
    if corners is None:
        points = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1).reshape(-1, len(shape))
    else:
        index = np.unravel_index(corners, tuple(n + 1 for n in shape))
        points = np.stack([t[i] for t, i in zip(ticks, index, strict=True)], axis=1)
    return (points if direction is None else points @ direction.T) + np.asarray(origin)


#: The reach of an image's band along the grid's edges (units of ``h``, the domains'
#: :attr:`~ndboundary.Domain.band_reach`). On voxel balls of 96^3 and 128^3 the level set
#: of ``relax_image`` lay as close to the whole grid's with a band of 8 h or 10 h as of
#: 13 h (0.0095, 0.0094 and 0.0092 h on average at 96^3; 0.0081 h at 128^3 for all
#: three), against the target 0.01 h (``benchmarks/band.py --cases voxels-96,voxels-128
#: --widths 8,10,auto``); cells of other meshes keep 12 h.
GRID_BAND_REACH = 10.0

#: The inner band of an image band's integration, in steps along its coarsest axis: the
#: pixels with a corner within 4 steps of zeta, half a step more so that no corner's
#: distance ties it (rounding would decide).
INTEGRATION_STEPS = 4.5


def grid_integration_reach(shape, spacing):
    """The half-width (units of the grid's mean edge length ``h``) of the inner band that
    a band of an image integrates (:attr:`~ndboundary.Domain.integration_reach`):
    :data:`INTEGRATION_STEPS` steps along the coarsest axis.

    On voxel balls of 96^3 and 128^3 the level set then lies as near the whole grid's as
    when the whole band is integrated (``benchmarks/band.py --cases voxels-96,voxels-128
    --integrate-whole-band``), in half the time. Counted in ``h`` instead, the reach would
    span fewer of a scan's thick slices: on the prostate's 4 mm slices (``h`` 1.7 mm) the
    regions' volumes moved by 0.17 %.

    Examples
    --------
    >>> from ndboundary.domains.image import grid_integration_reach
    >>> grid_integration_reach((10, 10, 10), (1.0, 1.0, 1.0)), grid_integration_reach((10, 10), (1.0, 3.0))
    (4.5, 6.75)
    """
    from ..pipeline.grid_band import grid_mean_edge_length  # the pipeline builds on the domains

    return INTEGRATION_STEPS * float(max(spacing)) / grid_mean_edge_length(shape, spacing)


def _integration_reach(grid) -> float:
    """A band of the image integrates the pixels within :data:`INTEGRATION_STEPS` steps
    of its coarsest axis from zeta (:func:`grid_integration_reach`).
    """
    return grid_integration_reach(grid.shape, grid.spacing)


#: Spacings whose largest is at most this times the smallest count as cubic for
#: :func:`grid_multigrid_sweeps`.
CUBIC_SPACING = 1.25


def grid_multigrid_sweeps(spacing):
    """Gauss-Seidel sweeps each way of the integration's V-cycle on a grid of this spacing
    (:attr:`~ndboundary.Domain.multigrid_sweeps`): one on cubic voxels (largest spacing
    at most :data:`CUBIC_SPACING` times the smallest), two otherwise (pixels' systems are
    factorised, not iterated).

    On the inner bands of voxel balls one sweep each way took 19 iterations instead of
    17 and 5.1 s instead of 6.1 s at 256^3 (941 K unknowns), 1.03 s instead of 1.10 s at
    128^3 (``benchmarks/solvers.py --sizes voxels:128,voxels:256 --methods
    amg-pcg-sweeps1,amg-pcg-sweeps2``); on voxels of 1 x 1 x 3 it took 27 iterations
    instead of 21 for as much time, and on tetrahedral and hexahedral meshes more time,
    where two stay.

    Examples
    --------
    >>> from ndboundary.domains.image import grid_multigrid_sweeps
    >>> grid_multigrid_sweeps((1.0, 1.0, 1.0)), grid_multigrid_sweeps((0.6, 0.6, 4.0))
    (1, 2)
    """
    spacing = np.asarray(spacing, dtype=np.float64)
    return 1 if spacing.size == 3 and spacing.max() <= CUBIC_SPACING * spacing.min() else 2


def _multigrid_sweeps(grid) -> int:
    return grid_multigrid_sweeps(grid.spacing)


class ImageGrid:
    """The pixels or voxels of an image as a domain: ``ImageGrid(shape, spacing=, origin=)``.

    Calling ``ImageGrid`` builds a :class:`PixelGrid` (2-D, a
    :class:`~ndboundary.PolygonMesh` of quadrilaterals) or a :class:`VoxelGrid` (3-D, a
    :class:`~ndboundary.PolyhedralMesh` of hexahedra); both are ``ImageGrid`` instances.

    Parameters
    ----------
    shape : tuple of int
        The image's shape, 2 or 3 axes.
    spacing : float or sequence of float, default=1.0
        The distance between pixel centres along each axis (anisotropic allowed).
    origin : float or sequence of float, default=0.0
        The centre of pixel ``(0, 0[, 0])``.
    direction : array_like of shape (dim, dim), optional
        For an oblique scan: the unit vectors of the image's axes as columns, orthonormal
        (``ndboundary.io.read_image(path, oblique=True).direction``); pixel ``index`` is
        then centred at ``origin + direction @ (index * spacing)``, and every output is in
        those world coordinates.
    **kwargs
        Passed to the mesh (``laplacian``, ``stabilization``).

    Attributes
    ----------
    shape, spacing, origin : tuple
    direction : ndarray or None

    Examples
    --------
    >>> from ndboundary import ImageGrid
    >>> grid = ImageGrid((3, 4), spacing=(1.0, 0.5), origin=(10.0, 0.0))
    >>> grid.n_elements, grid.n_vertices, float(grid.A.sum())
    (12, 20, 6.0)
    >>> grid.element_centroids()[5].tolist()  # pixel (1, 1)
    [11.0, 0.5]
    >>> isinstance(grid, ImageGrid), type(ImageGrid((2, 2, 2))).__name__
    (True, 'VoxelGrid')
    """

    band_reach = GRID_BAND_REACH
    integration_reach = property(_integration_reach)
    multigrid_sweeps = property(_multigrid_sweeps)

    def __new__(cls, shape=None, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        """A :class:`PixelGrid` or :class:`VoxelGrid`, by the number of axes of ``shape``
        (which a subclass, and unpickling, need not give).
        """
        if cls is ImageGrid:
            shape = grid_geometry(shape, spacing, origin)[0]
            cls = PixelGrid if len(shape) == 2 else VoxelGrid
        return object.__new__(cls)

    def __repr__(self):
        return f"{type(self).__name__}(shape={self.shape}, spacing={self.spacing}, origin={self.origin})"

    def subdomain(self, mask):
        """The pixels selected by ``mask`` as a :class:`GridBand` (see :meth:`Domain.subdomain`)."""
        return _grid_subdomain(self, mask)

    @cached_property
    def usual_degree(self) -> float:
        """The :attr:`~ndboundary.Domain.usual_degree`, counted from the shape
        (:func:`grid_usual_degree`) rather than from the pixels' adjacency.
        """
        return grid_usual_degree(self.shape)

    def _smoothing(self, adjacency, passes):
        return anisotropic_smoothing(self, adjacency, passes)


def anisotropic_smoothing(domain, adjacency, passes):
    """:meth:`~ndboundary.Domain.smooth_field`'s weights and sweeps on a grid of pixels
    (``domain``, an :class:`ImageGrid` or a :class:`GridBand`) whose spacing differs between
    axes: each neighbour weighs ``(min(spacing) / d)^2``, ``d`` the distance to it, so that
    a sweep spreads the field by as much along every axis (a diffusion by ``min(spacing)``),
    not by each axis's spacing; the sweeps stay as many.

    With uniform weights, a ball on voxels of spacing (1, 1, 3) bulged at its poles, where
    the field was smoothed 3 times as far along the coarse axis as across it. More sweeps,
    spreading the field as far as on a grid of the coarsest spacing, took the ball nearer
    still but cost small regions of thick slices their volume (README, "The field smoothed
    alike along every axis").

    Examples
    --------
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.domains.image import anisotropic_smoothing
    >>> grid = ImageGrid((3, 3), spacing=(1.0, 2.0))
    >>> W, passes = anisotropic_smoothing(grid, grid.adjacency, 10)
    >>> sorted(set(W.data.tolist())), passes
    ([0.25, 1.0], 10)
    >>> square = ImageGrid((3, 3))
    >>> anisotropic_smoothing(square, square.adjacency, 10)[0] is square.adjacency
    True
    """
    spacing = np.asarray(domain.spacing, dtype=np.float64)
    if spacing.max() <= spacing.min() * (1.0 + 1e-9):
        return adjacency, passes
    # a face neighbour's axis is read off the step between the two pixels' indices in the
    # whole grid (C order): no coordinates per pair, a band of many millions included
    shape = np.asarray(domain.shape, dtype=np.int64)
    strides = np.append(np.cumprod(shape[::-1])[::-1][1:], 1)
    axes = zip(strides, spacing, shape, strict=True)
    by_stride = {int(stride): (spacing.min() / h) ** 2 for stride, h, n in axes if n > 1}
    index = getattr(domain, "pixels", None)
    pairs = adjacency.tocoo()
    if index is None:
        step = np.abs(pairs.col.astype(np.int64) - pairs.row)
    else:
        step = np.abs(index[pairs.col].astype(np.int64) - index[pairs.row])
    known = np.array(sorted(by_stride))
    at = np.searchsorted(known, step)
    if not np.array_equal(known[np.minimum(at, known.size - 1)], step):
        raise ValueError("the smoothing's neighbours are not face neighbours of the grid")
    weights = pairs.data * np.array([by_stride[k] for k in known])[at]
    return sp.csr_matrix((weights, (pairs.row, pairs.col)), shape=adjacency.shape), passes


def grid_usual_degree(shape):
    """The :attr:`~ndboundary.Domain.usual_degree` of an image grid of ``shape``: the 90th
    percentile of its pixels' numbers of face neighbours, counted from the shape alone
    (a pixel's count is the sum over the axes of its neighbours along each).

    Examples
    --------
    >>> from ndboundary.domains.image import grid_usual_degree
    >>> grid_usual_degree((40, 40, 40)), grid_usual_degree((2, 3))
    (6.0, 3.0)
    """
    counts = np.ones(1, dtype=np.int64)  # counts[k]: the pixels with k neighbours so far
    for n in shape:
        along = np.zeros(3, dtype=np.int64)  # the pixels with 0, 1 and 2 neighbours along the axis
        along[0], along[1], along[2] = (n == 1), 2 * (n > 1), max(n - 2, 0)
        counts = np.convolve(counts, along)
    position = 0.9 * (counts.sum() - 1)  # numpy's linear percentile over the sorted counts
    ends = np.cumsum(counts)
    low, high = np.searchsorted(ends, [np.floor(position), np.ceil(position)], side="right")
    return float(low + (position - np.floor(position)) * (high - low))


class PixelGrid(ImageGrid, PolygonMesh):
    """The pixels of a 2-D image (see :class:`ImageGrid`)."""

    def __init__(self, shape, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self.shape, self.spacing, self.origin = grid_geometry(shape, spacing, origin)
        if len(self.shape) != 2:
            raise ValueError(f"a PixelGrid is 2-D, got shape {self.shape}")
        self.direction = grid_direction(direction, 2)
        points = corner_points(self.shape, self.spacing, self.origin, self.direction)
        (s0, s1), o = _pixel_strides(self), _lowest_corners(self.shape, np.arange(int(np.prod(self.shape))))
        quads = np.stack([o, o + s0, o + s0 + s1, o + s1], axis=1)  # counter-clockwise in (x0, x1)
        PolygonMesh.__init__(self, points, quads, **kwargs)


def _faces_part(i, doc):
    """A read-only property: item ``i`` of the voxels' faces, found when first read
    (``_Voxels._faces``).
    """
    return property(lambda self: self._faces[i], doc=doc)


class _Voxels(PolyhedralMesh):
    """Hexahedra that are the voxels of a grid: their stiffness and gradient are built
    from the one box they all are (:func:`~ndboundary.domains.voxels.voxel_stiffness`).

    The faces' geometry, which a general polyhedral mesh computes when it is built, is
    found when first read: every face of one axis is the same rectangle, so the relaxation,
    which reads none of it, neither computes nor stores an array of it per face.
    """

    def simplicial_refinement(self):
        """The general refinement (:meth:`PolyhedralMesh.simplicial_refinement`), read off
        the voxels' faces and corners (:func:`~ndboundary.domains.voxels.voxel_refinement`).
        """
        return voxel_refinement(self)

    @cached_property
    def box(self):
        """What every voxel shares (:func:`~ndboundary.domains.voxels.box_constants`)."""
        return box_constants(self.spacing, self.direction)

    @property
    def n_elements(self):
        """Number of voxels."""
        return self._n_voxels

    @cached_property
    def _faces(self):
        """``(face_indices, face_offsets, cell_faces, cell_offsets, cell_face_signs,
        axis_counts)`` (:func:`~ndboundary.domains.voxels.voxel_faces`), found when first
        read: the relaxation reads them only to find the face adjacency, so a band drops
        them once it has, and a large grid never holds them unread.
        """
        strides = corner_strides(self.shape)
        fi, fo, ci, co, signs, counts = voxel_faces(self.shape, strides, getattr(self, "pixels", None))
        corners = getattr(self, "corners", None)
        if corners is not None:
            fi = np.searchsorted(corners, fi)  # the band's numbering of the grid's corners
        if self.direction is not None and np.linalg.det(self.direction) < 0:
            signs = -signs  # a reflection turns every face
        return fi, fo, ci, co, signs, counts

    face_indices = _faces_part(
        0,
        """Face ``f`` is ``face_indices[face_offsets[f]:face_offsets[f + 1]]`` (counter-clockwise
        seen from its axis' positive side; see :class:`~ndboundary.PolyhedralMesh`).""",
    )
    face_offsets = _faces_part(1, "See :attr:`face_indices`.")
    cell_faces = _faces_part(2, "Voxel ``e`` has the faces ``cell_faces[6 e:6 e + 6]``: low then high along each axis.")
    cell_offsets = _faces_part(3, "See :attr:`cell_faces`.")
    cell_face_signs = _faces_part(
        4, "-1 for a voxel's low faces, +1 for its high ones (outward; turned by a reflection)."
    )
    _axis_counts = _faces_part(5, "The number of faces across each axis.")

    @cached_property
    def _face_ids(self):
        """Every face is listed once."""
        return np.arange(self.n_faces)

    @cached_property
    def _face_axes(self):
        """Every face's axis."""
        return np.repeat(np.arange(3), self._axis_counts)

    @cached_property
    def face_areas(self):
        """Every face's area vector, shape (n_faces, 3)."""
        return self.box[0][self._face_axes]

    @cached_property
    def face_centres(self):
        """Every face's centre, shape (n_faces, 3)."""
        return self.points[self.face_indices[::4]] + self.box[1][self._face_axes]

    @cached_property
    def fan_areas(self):
        """The vector area of each face corner's fan triangle, a quarter of its face's."""
        return np.repeat(self.face_areas / 4.0, 4, axis=0)

    @cached_property
    def _face_corners(self):
        return ragged_next(self.face_offsets)

    @property
    def face_owner(self):
        """Every face corner's face."""
        return self._face_corners[0]

    @property
    def face_next(self):
        """Every face corner's next corner in its face."""
        return self._face_corners[1]

    @cached_property
    def _pair_grads(self):
        """The Green-Gauss coefficient of every (voxel, corner) pair, the box's for all."""
        return np.tile(self.box[2], (self.n_elements, 1))

    def build_stiffness(self):
        """The stiffness (see :class:`~ndboundary.PolyhedralMesh`), from one voxel's matrix."""
        if self.laplacian != "consistent":
            return super().build_stiffness()
        return voxel_stiffness(self)

    def build_gradient(self):
        """The gradient operator (see :class:`~ndboundary.PolyhedralMesh`), in CSR form directly."""
        return voxel_gradient(self)

    def gradient(self, f):
        """Per-voxel gradient of the vertex function ``f``, shape (n_elements, 3): ``G @ f``
        without the matrix, each voxel's corner values times the coefficients every voxel
        shares (the matrix would hold 24 entries a voxel that repeat the same 24 numbers).
        """
        f = np.asarray(f, dtype=np.float64).reshape(self.n_vertices)
        return f[_corners_of(self)] @ self.box[2]

    def div(self, X):
        """Weak divergence ``G^T diag(A) X`` of a per-voxel field ``X`` of shape
        (n_elements, 3), without the matrix (see :meth:`gradient`).
        """
        X = np.asarray(X, dtype=np.float64).reshape(self.n_elements, 3)
        weights = (X * self.A[:, None]) @ self.box[2].T  # (n_elements, 8): each corner's share
        return np.bincount(self.cell_vertices[1], weights=weights.reshape(-1), minlength=self.n_vertices)

    def build_edges(self):
        """The unique edges, ``i < j``, from the voxels' corners without a sort."""
        return voxel_edges(self)

    def build_adjacency(self):
        """Voxels sharing a face (:func:`~ndboundary.domains.voxels.voxel_adjacency`)."""
        return voxel_adjacency(self)

    def vertices_of(self, elements):
        """The vertices of the voxels selected by the boolean mask ``elements``, read off
        their corners, without the incidence (8 entries a voxel) the general query reads.
        """
        elements = as_mask(elements, self.n_elements, "elements")
        out = np.zeros(self.n_vertices, dtype=bool)
        out[_corners_of(self)[elements].ravel()] = True
        return out

    def elements_at(self, vertices):
        """The voxels holding a vertex selected by the boolean mask ``vertices``, read off
        their corners a column at a time.
        """
        vertices = as_mask(vertices, self.n_vertices, "vertices")
        corners = _corners_of(self)
        out = vertices[corners[:, 0]]
        for c in range(1, 8):
            out |= vertices[corners[:, c]]
        return out

    def _meeting_codes(self, codes, n_codes):
        """The (vertex, code) pairs of :meth:`~ndboundary.Domain.code_boundaries`, read
        off the voxels' corners without the incidence.
        """
        corners = _corners_of(self)
        lowest = np.full(self.n_vertices, n_codes, dtype=np.int64)
        highest = np.zeros(self.n_vertices, dtype=np.int64)
        for c in range(8):
            np.minimum.at(lowest, corners[:, c], codes)
            np.maximum.at(highest, corners[:, c], codes)
        mixed = lowest < highest  # a vertex of no voxel keeps (n_codes, 0)
        near = np.flatnonzero(self.elements_at(mixed))
        vertex = corners[near].ravel()
        keep = mixed[vertex]
        return vertex[keep], np.repeat(codes[near], 8)[keep]

    def element_centroids(self):
        """Vertex means of the voxels, shape (n_elements, 3): their corners summed in
        order, as the general mean sums them, without the (voxel, corner) table.
        """
        return corner_means(self.points, _corners_of(self))

    def centroids_of(self, elements):
        """:meth:`element_centroids` of the voxels ``elements`` alone."""
        return corner_means(self.points, _corners_of(self), np.asarray(elements))

    def element_max(self, f):
        """Per voxel, the largest value of the vertex function ``f`` at its corners."""
        return corner_max(f, _corners_of(self))


class VoxelGrid(ImageGrid, _Voxels):
    """The voxels of a 3-D volume (see :class:`ImageGrid`)."""

    def __init__(self, shape, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self.shape, self.spacing, self.origin = grid_geometry(shape, spacing, origin)
        if len(self.shape) != 3:
            raise ValueError(f"a VoxelGrid is 3-D, got shape {self.shape}")
        self.direction = grid_direction(direction, 3)
        _init_voxels(self, None, kwargs)

    # The whole grid's tables are built when first read: relaxed region by region
    # (``relax_image`` with many labels), a grid serves as the domain its bands are cut
    # from and its results live on, and an atlas's 23 M voxels would hold 3.7 GB of
    # corners, coordinates and volumes that nothing reads.

    @cached_property
    def cell_vertices(self):
        """The (voxel, corner) pairs, 8 a voxel in :data:`CORNER_BITS` order."""
        n = self._n_voxels
        corners = _lowest_corners(self.shape, np.arange(n))[:, None] + CORNER_BITS @ corner_strides(self.shape)
        return np.repeat(np.arange(n), 8), corners.ravel()

    @cached_property
    def points(self):
        """The corners' coordinates, shape (n_vertices, 3), in the grid's C order."""
        return corner_points(self.shape, self.spacing, self.origin, self.direction)

    @cached_property
    def _volumes(self):
        return self.build_measures()

    def build_measures(self):
        """The voxels' volumes, all alike."""
        return np.full(self._n_voxels, float(np.prod(self.spacing)))

    @property
    def n_vertices(self):
        """Number of vertices (the grid's corners)."""
        return int(np.prod(np.asarray(self.shape) + 1))

    @property
    def dim(self):
        """3: the corners' coordinates."""
        return 3

    def element_max(self, f):
        """Per voxel, the largest value of the vertex function ``f`` at its corners, a
        slab of voxels at a time unless their corners are held: no table of every
        voxel's corners.
        """
        if "cell_vertices" in self.__dict__:
            return super().element_max(f)
        f = np.asarray(f)
        out = np.empty(self._n_voxels, dtype=f.dtype)
        offsets = CORNER_BITS @ corner_strides(self.shape)
        step = max(1, SLAB_VOXELS // (self.shape[1] * self.shape[2])) * self.shape[1] * self.shape[2]
        for start in range(0, self._n_voxels, step):
            voxels = np.arange(start, min(start + step, self._n_voxels))
            out[voxels] = corner_max(f, _lowest_corners(self.shape, voxels)[:, None] + offsets)
        return out


class GridBand:
    """Some of the pixels or voxels of an image, as a domain of their own: the band of a
    label image around its boundaries, built without the whole grid.

    A :class:`PixelBand` (2-D, a :class:`~ndboundary.PolygonMesh` of quadrilaterals) or a
    :class:`VoxelBand` (3-D, a :class:`~ndboundary.PolyhedralMesh` of hexahedra) has the
    ``pixels`` of the grid ``ImageGrid(shape, spacing=, origin=, direction=)`` as its
    elements, in that order, and the corners they hold as its vertices, in the grid's C
    order: the mesh, geometry and operators of the whole grid's
    :meth:`~ndboundary.Domain.subdomain` of the same pixels, built from their indices.
    :func:`~ndboundary.relax_image` relaxes a large image on it, so that its cost follows
    the boundaries, not the image.

    Attributes
    ----------
    shape, spacing, origin : tuple
        The whole grid's.
    direction : ndarray or None
    pixels : ndarray of int64
        The pixels (voxels) held, as indices into the whole grid (C order), increasing.
    corners : ndarray of int64
        The vertices' indices among the whole grid's corners (C order over ``shape + 1``).
    outside : dict
        Each label of the pixels left out, with their total area (volume): what
        :meth:`measures_outside` adds to a relaxed region's measure. Empty until set.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.image import GridBand
    >>> band = GridBand((4, 4, 4), np.arange(16, 32), spacing=0.5)  # the second layer of voxels
    >>> band.n_elements, band.n_vertices, float(band.A.sum())
    (16, 50, 2.0)
    """

    band_reach = GRID_BAND_REACH
    integration_reach = property(_integration_reach)
    multigrid_sweeps = property(_multigrid_sweeps)

    def __new__(cls, shape=None, pixels=None, **kwargs):
        """A :class:`PixelBand` or :class:`VoxelBand`, by the number of axes of ``shape``
        (which a subclass, and unpickling, need not give).
        """
        if cls is GridBand:
            if shape is None or pixels is None:
                raise TypeError("GridBand needs the grid's shape and the band's pixels")
            cls = PixelBand if len(tuple(shape)) == 2 else VoxelBand
        return object.__new__(cls)

    def _set_grid(self, shape, pixels, spacing, origin, direction):
        self.shape, self.spacing, self.origin = grid_geometry(shape, spacing, origin)
        self.direction = grid_direction(direction, len(self.shape))
        pixels = np.asarray(pixels)
        if pixels.ndim != 1 or pixels.size == 0 or not np.issubdtype(pixels.dtype, np.integer):
            raise ValueError(f"pixels must be a non-empty 1-D array of pixel indices, got shape {pixels.shape}")
        size = int(np.prod(self.shape))
        if pixels[0] < 0 or pixels[-1] >= size or np.any(np.diff(pixels) <= 0):
            raise ValueError(f"pixels must be increasing indices in [0, {size}) of the grid {self.shape}")
        self.pixels = pixels.astype(np.int64)
        self.outside = {}

    @cached_property
    def vertex_components(self):
        """Connected components of the vertices: ``(n_components, labels)``.

        Pixels that share a corner share a vertex, so the components are those of the
        pixels on the index grid with diagonal neighbours (:func:`scipy.ndimage.label`),
        found without the mesh's edges.
        """
        _, box, index = _pixel_box(self.shape, self.pixels)  # the pixels' box, not the grid
        mask = np.zeros(box, dtype=bool)
        mask[index] = True
        labels, n = ndimage.label(mask, structure=np.ones((3,) * len(self.shape), dtype=bool))
        element, vertex = self._element_vertex_pairs()
        comp = np.empty(self.n_vertices, dtype=np.int32)
        comp[vertex] = labels[index][element] - 1
        return int(n), comp

    def subdomain(self, mask):
        """The pixels selected by ``mask`` as a :class:`GridBand` of their own (see
        :meth:`Domain.subdomain`): the mesh a general cut gives, built from their indices.
        """
        return _grid_subdomain(self, mask)

    def measures_outside(self, classes):
        """The area (volume) of each of ``classes`` among the pixels left out, shape ``(len(classes),)``."""
        return np.array([self.outside.get(c, 0.0) for c in np.asarray(classes).tolist()], dtype=np.float64)

    def _smoothing(self, adjacency, passes):
        return anisotropic_smoothing(self, adjacency, passes)

    def __repr__(self):
        return f"{type(self).__name__}(shape={self.shape}, n_pixels={self.pixels.size}, spacing={self.spacing})"


class PixelBand(GridBand, PolygonMesh):
    """Some pixels of a 2-D image (see :class:`GridBand`)."""

    def __init__(self, shape, pixels, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self._set_grid(shape, pixels, spacing, origin, direction)
        if len(self.shape) != 2:
            raise ValueError(f"a PixelBand is 2-D, got shape {self.shape}")
        (s0, s1), o = _pixel_strides(self), _lowest_corners(self.shape, self.pixels)
        quads = np.stack([o, o + s0, o + s0 + s1, o + s1], axis=1)
        self.corners = unique_values(quads.ravel())
        points = corner_points(self.shape, self.spacing, self.origin, self.direction, self.corners)
        PolygonMesh.__init__(self, points, np.searchsorted(self.corners, quads), **kwargs)

    def _element_vertex_pairs(self):
        return self._corners[0], self.indices


class VoxelBand(GridBand, _Voxels):
    """Some voxels of a 3-D volume (see :class:`GridBand`)."""

    def __init__(self, shape, pixels, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self._set_grid(shape, pixels, spacing, origin, direction)
        if len(self.shape) != 3:
            raise ValueError(f"a VoxelBand is 3-D, got shape {self.shape}")
        _init_voxels(self, self.pixels, kwargs)

    def _element_vertex_pairs(self):
        return self.cell_vertices


def _grid_subdomain(mesh, mask):
    """``(band, vertices)``: the :class:`GridBand` of the pixels of ``mesh`` (an
    :class:`ImageGrid` or a :class:`GridBand`) that ``mask`` selects, and the mesh's
    vertex of each of its vertices. It keeps its parent's :attr:`~Domain.usual_degree`,
    as every band does.
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (mesh.n_elements,):
        raise ValueError(f"mask must hold one value per pixel ({mesh.n_elements}), got shape {mask.shape}")
    chosen = np.flatnonzero(mask)
    parent = getattr(mesh, "pixels", None)
    band = GridBand(
        mesh.shape, chosen if parent is None else parent[chosen], spacing=mesh.spacing, origin=mesh.origin,
        direction=mesh.direction, laplacian=mesh.laplacian, stabilization=mesh.stabilization,
    )  # fmt: skip
    band.usual_degree = mesh.usual_degree
    corners = getattr(mesh, "corners", None)
    return band, (band.corners if corners is None else np.searchsorted(corners, band.corners))


def grid_facets(grid, region1, near=None):
    """The facets between the pixels of ``region1`` and the others, on an image grid or band.

    Parameters
    ----------
    grid : ImageGrid or GridBand
    region1 : ndarray of bool of shape (grid.n_elements,)
    near : ndarray of bool of shape (grid.n_elements,), optional
        The pixels to look around (every pixel by default): the facets of the pixels of
        ``region1`` among them are found. Those that touch the jagged boundary hold every
        facet, so that the search follows the boundary rather than the grid.

    Returns
    -------
    facets : ndarray of int of shape (n_facets, 2 ** (dim - 1))
        Each facet's corners, as vertices of ``grid``, in cyclic order.
    normals : ndarray of shape (n_facets, dim)
        Each facet's unit normal, pointing out of ``region1`` (in world coordinates).
    areas : ndarray of shape (n_facets,)
        Each facet's length (2-D) or area (3-D).
    inner, outer : ndarray of int of shape (n_facets, 2 ** (dim - 1))
        The corners of the face opposite the facet in the pixel of ``region1`` and in the
        other pixel: with the facet's, the pixel's corners, whose mean is the value at
        its centre.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.domains.image import grid_facets
    >>> grid = ImageGrid((3, 4), spacing=(1.0, 0.5))
    >>> region1 = np.zeros((3, 4), dtype=bool)
    >>> region1[1, 1:3] = True  # two pixels side by side along the second axis
    >>> facets, normals, areas, inner, outer = grid_facets(grid, region1.ravel())
    >>> facets.shape, normals.sum(axis=0).tolist(), float(areas.sum())  # perimeter 2 x (1 + 1)
    ((6, 2), [0.0, 0.0], 4.0)
    >>> centres = grid.points[np.hstack([facets, inner])].mean(axis=1)  # the pixels of region 1
    >>> np.unique(centres, axis=0).tolist()
    [[1.0, 0.5], [1.0, 1.0]]
    """
    shape, dim = grid.shape, len(grid.shape)
    pixels = getattr(grid, "pixels", None)
    corners = getattr(grid, "corners", None)
    mine = np.flatnonzero(region1 if near is None else region1 & near)
    held = mine if pixels is None else pixels[mine]
    index = np.unravel_index(held, shape)
    cshape = tuple(n + 1 for n in shape)
    pstrides = np.cumprod((1,) + shape[:0:-1])[::-1]
    cstrides = np.cumprod((1,) + cshape[:0:-1])[::-1]
    lowest = np.ravel_multi_index(index, cshape)
    axes = np.eye(dim) if grid.direction is None else grid.direction.T
    facets, normals, areas, inner_c, outer_c = [], [], [], [], []

    def vertices(c):
        return c if corners is None else np.searchsorted(corners, c)

    for a in range(dim):
        # the facet's corners: the pixel's lowest corner (one step along a for the facet
        # above it), and every combination of one step along the other axes, in turn
        offsets = np.zeros(1, dtype=np.int64)
        for b in [b for b in range(dim) if b != a]:
            offsets = np.concatenate([offsets, offsets[::-1] + cstrides[b]])
        area = np.prod([grid.spacing[b] for b in range(dim) if b != a])
        for side in (1, -1):
            inner = np.flatnonzero(index[a] < shape[a] - 1 if side == 1 else index[a] > 0)
            other = held[inner] + side * pstrides[a]
            if pixels is not None:  # the band's element of each neighbour, where the band holds it
                at = np.minimum(np.searchsorted(pixels, other), pixels.size - 1)
                kept = pixels[at] == other
                inner, other = inner[kept], at[kept]
            inner = inner[~region1[other]]
            facet = lowest[inner, None] + (cstrides[a] if side == 1 else 0) + offsets[None, :]
            facets.append(vertices(facet))
            inner_c.append(vertices(facet - side * cstrides[a]))
            outer_c.append(vertices(facet + side * cstrides[a]))
            normals.append(np.broadcast_to(side * axes[a], (inner.size, dim)))
            areas.append(np.full(inner.size, area))
    return tuple(np.concatenate(x) for x in (facets, normals, areas, inner_c, outer_c))


#: Voxels a pass of :meth:`VoxelGrid.element_max` reads at a time (whole slabs of the
#: first axis, at least one): 64 MB of corners.
SLAB_VOXELS = 1 << 20


def _lowest_corners(shape, pixels):
    """The lowest corner of each pixel, as an index among the grid's corners."""
    return np.ravel_multi_index(np.unravel_index(pixels, shape), tuple(n + 1 for n in shape))


def _pixel_box(shape, pixels):
    """``(start, box, index)``: the lowest index along each axis of the ``pixels`` (indices
    into a grid of ``shape``, at least one), the shape of the box of pixels from there to
    their highest, and each pixel's index in that box, one array per axis.

    Tables over the box instead of the grid keep the work on a band of a large image to
    the size of the band.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.image import _pixel_box
    >>> start, box, index = _pixel_box((4, 5), np.array([6, 8, 13]))  # (1, 1), (1, 3), (2, 3)
    >>> start.tolist(), box, [i.tolist() for i in index]
    ([1, 1], (2, 3), [[0, 0, 1], [0, 2, 2]])
    """
    index = np.unravel_index(pixels, shape)
    start = np.array([int(i.min()) for i in index], dtype=np.int64)
    box = tuple(int(i.max()) - int(s) + 1 for i, s in zip(index, start, strict=True))
    return start, box, tuple(i - s for i, s in zip(index, start, strict=True))


def _pixel_strides(grid):
    """The corners' strides along the two axes, swapped for a reflection (the quads stay
    counter-clockwise in the grid's axes).
    """
    s0, s1 = grid.shape[1] + 1, 1
    if grid.direction is not None and np.linalg.det(grid.direction) < 0:
        s0, s1 = s1, s0
    return s0, s1


def _init_voxels(mesh, voxels, kwargs):
    """Build the hexahedra of the ``voxels`` of ``mesh``'s grid: their corners and points;
    the faces are found when first read (``_Voxels._faces``). For None (every voxel),
    :class:`VoxelGrid` builds its corners and points when first read.
    """
    laplacian = kwargs.pop("laplacian", "consistent")
    stabilization = check_laplacian_options(laplacian, kwargs.pop("stabilization", 4.0))
    if kwargs:
        raise TypeError(f"{type(mesh).__name__} got unexpected keyword arguments {sorted(kwargs)}")
    shape = mesh.shape
    mesh.stabilization, mesh.laplacian = stabilization, laplacian
    if voxels is None:  # the whole grid: its tables are built when read (VoxelGrid)
        mesh._n_voxels = int(np.prod(shape))
        return
    # the corners the voxels hold, numbered by a table over the corners of the voxels'
    # bounding box, without a sort: its size follows the band, not the grid
    start, box, index = _pixel_box(shape, voxels)
    cshape = tuple(n + 1 for n in box)
    lowest = np.ravel_multi_index(index, cshape)
    cell_vertices = lowest[:, None] + CORNER_BITS @ corner_strides(box)
    used, remap = used_vertices(cell_vertices, int(np.prod(cshape)))
    cell_vertices = remap[cell_vertices]
    mesh.corners = np.ravel_multi_index(
        tuple(i + s for i, s in zip(np.unravel_index(used, cshape), start, strict=True)),
        tuple(n + 1 for n in shape),
    )  # increasing: the box's C order is the grid's
    mesh.points = corner_points(shape, mesh.spacing, mesh.origin, mesh.direction, mesh.corners)
    mesh._n_voxels = cell_vertices.shape[0]
    mesh._volumes = np.full(cell_vertices.shape[0], float(np.prod(mesh.spacing)))
    mesh.__dict__["cell_vertices"] = (np.repeat(np.arange(cell_vertices.shape[0]), 8), cell_vertices.ravel())
