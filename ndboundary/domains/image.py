"""Pixel and voxel grids: :class:`ImageGrid`, the domain of a label image or volume.

A label image of shape ``(n0, n1)`` or volume of shape ``(n0, n1, n2)`` has one element
per pixel or voxel, in C order (the last index fastest, as ``labels.ravel()`` lists
them), each centred at ``origin + index * spacing``: the NIfTI / ITK and scikit-image
convention, so that what is relaxed lies where the scanner put it. The grid's vertices
are the pixels' corners, half a spacing from the centres. Pixels are quadrilaterals of a
:class:`~ndboundary.PolygonMesh`, voxels hexahedra of a
:class:`~ndboundary.PolyhedralMesh`: every operator, padding and band of those meshes
serves the grids unchanged, with anisotropic spacing. A voxel grid's faces and geometry
come from its structure (:mod:`~ndboundary.domains.voxels`) instead of a search and a
computation per cell, and the band and the padding cut from it keep that geometry
(:mod:`~ndboundary.domains.polyhedral_reuse`).
"""

from __future__ import annotations

import numpy as np

from .polygon import PolygonMesh
from .polyhedral import PolyhedralMesh
from .cell_operators import check_laplacian_options
from .voxels import box_geometry, voxel_faces

__all__ = ["ImageGrid", "PixelGrid", "VoxelGrid"]


def grid_geometry(shape, spacing, origin):
    """``(shape, spacing, origin)`` checked, as tuples of one int / float per axis."""
    try:
        shape = tuple(int(n) for n in shape)
    except TypeError:
        raise TypeError(f"shape must be a sequence of integers, got {shape!r}") from None
    dim = len(shape)
    if dim not in (2, 3):
        raise ValueError(f"an image grid is 2-D or 3-D, got shape {shape}")
    if min(shape) < 1:
        raise ValueError(f"shape must hold positive sizes, got {shape}")
    out = []
    for name, value in (("spacing", spacing), ("origin", origin)):
        arr = np.asarray(value, dtype=np.float64)
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


def grid_points(shape, spacing, origin, direction=None):
    """The pixels' corners (C order over ``shape + 1``) and each pixel's lowest corner."""
    corners = [spacing[a] * (np.arange(n + 1) - 0.5) for a, n in enumerate(shape)]
    points = np.stack(np.meshgrid(*corners, indexing="ij"), axis=-1).reshape(-1, len(shape))
    points = (points if direction is None else points @ direction.T) + np.asarray(origin)
    strides = np.cumprod((1,) + tuple(n + 1 for n in shape[::-1]))[:-1][::-1]
    index = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, len(shape))
    return points, index @ strides, strides


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

    def __new__(cls, shape, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        """A :class:`PixelGrid` or :class:`VoxelGrid`, by the number of axes of ``shape``."""
        if cls is ImageGrid:
            shape = grid_geometry(shape, spacing, origin)[0]
            cls = PixelGrid if len(shape) == 2 else VoxelGrid
        return object.__new__(cls)

    def __repr__(self):
        return f"{type(self).__name__}(shape={self.shape}, spacing={self.spacing}, origin={self.origin})"


class PixelGrid(ImageGrid, PolygonMesh):
    """The pixels of a 2-D image (see :class:`ImageGrid`)."""

    def __init__(self, shape, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self.shape, self.spacing, self.origin = grid_geometry(shape, spacing, origin)
        if len(self.shape) != 2:
            raise ValueError(f"a PixelGrid is 2-D, got shape {self.shape}")
        self.direction = grid_direction(direction, 2)
        points, o, (s0, s1) = grid_points(self.shape, self.spacing, self.origin, self.direction)
        if self.direction is not None and np.linalg.det(self.direction) < 0:
            s0, s1 = s1, s0  # a reflection: keep the quads counter-clockwise
        quads = np.stack([o, o + s0, o + s0 + s1, o + s1], axis=1)  # counter-clockwise in (x0, x1)
        PolygonMesh.__init__(self, points, quads, **kwargs)


class VoxelGrid(ImageGrid, PolyhedralMesh):
    """The voxels of a 3-D volume (see :class:`ImageGrid`)."""

    def __init__(self, shape, *, spacing=1.0, origin=0.0, direction=None, **kwargs):
        self.shape, self.spacing, self.origin = grid_geometry(shape, spacing, origin)
        if len(self.shape) != 3:
            raise ValueError(f"a VoxelGrid is 3-D, got shape {self.shape}")
        self.direction = grid_direction(direction, 3)
        points, o, strides = grid_points(self.shape, self.spacing, self.origin, self.direction)
        laplacian = kwargs.pop("laplacian", "consistent")
        stabilization = check_laplacian_options(laplacian, kwargs.pop("stabilization", 4.0))
        if kwargs:
            raise TypeError(f"VoxelGrid got unexpected keyword arguments {sorted(kwargs)}")
        fi, fo, ci, co, signs = voxel_faces(self.shape, o, strides)
        if self.direction is not None and np.linalg.det(self.direction) < 0:
            signs = -signs  # a reflection turns every face
        geometry = box_geometry(self.shape, points, fi, o, strides, self.spacing, self.direction, signs)
        self._init_known(points, fi, fo, ci, co, laplacian, stabilization, geometry)
        self.__dict__["_face_ids"] = np.arange(fo.size - 1)  # every face is listed once
