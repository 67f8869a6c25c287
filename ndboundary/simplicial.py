"""Simplicial complexes of any dimension: segments, triangles, tetrahedra, n-simplices.

Operators (sign convention of :mod:`ndboundary.domain`: ``K`` is positive
semidefinite, ``Delta = -M^{-1} K``):

* gradient of the linear interpolant, per simplex: with ``E = [x1-x0, ..., xk-x0]``
  (dim x k) the barycentric gradients are the columns of ``E (E^T E)^{-1}``, exact for
  linear functions and intrinsic to the simplex (valid for surfaces in 3-D);
* ``A`` = simplex volume ``sqrt(det(E^T E)) / k!``;
* ``K = G^T diag(A) G`` -- the cotangent Laplacian on triangles, the cotangent
  Laplacian of tetrahedral meshes on tetrahedra;
* ``mass`` = each simplex's volume shared equally among its k+1 vertices.
"""

from __future__ import annotations

from functools import cached_property
from math import factorial

import numpy as np
import scipy.sparse as sp

from ._validation import check_cells, check_points
from .domain import Domain

__all__ = ["SimplicialComplex"]

_DEGENERATE_RTOL = 1e-10


def group_rows(rows):
    """Label equal rows of an integer array with the same id.

    Returns ``(ids, n_groups)``; ids follow the lexicographic order of the rows.
    """
    rows = np.asarray(rows)
    if rows.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), 0
    order = np.lexsort(rows.T[::-1])
    srt = rows[order]
    new = np.ones(rows.shape[0], dtype=bool)
    new[1:] = (srt[1:] != srt[:-1]).any(axis=1)
    ids = np.empty(rows.shape[0], dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, int(new.sum())


def shared_facet_adjacency(facet_ids, owner, n_elements):
    """Element adjacency: elements sharing a facet id (more than two sharing one are chained).

    ``facet_ids[i]`` is the id of a facet of element ``owner[i]``.
    """
    order = np.lexsort((owner, facet_ids))
    f, o = facet_ids[order], owner[order]
    same = (f[1:] == f[:-1]) & (o[1:] != o[:-1])
    i, j = o[:-1][same], o[1:][same]
    adj = sp.coo_matrix((np.ones(i.size), (i, j)), shape=(n_elements, n_elements))
    adj = (adj + adj.T).tocsr()
    adj.data[:] = 1.0
    return adj


def mixed_facets(facet_ids, owner, region1):
    """Indices (into ``facet_ids``) of one occurrence of every facet shared by both labels."""
    n_groups = int(facet_ids.max()) + 1
    lab = np.asarray(region1, dtype=np.float64)[owner]
    cnt = np.bincount(facet_ids, minlength=n_groups)
    ones = np.bincount(facet_ids, weights=lab, minlength=n_groups)
    mixed = (cnt >= 2) & (ones > 0) & (ones < cnt)
    first = np.unique(facet_ids, return_index=True)[1]
    return first[mixed]


def _simplex_geometry(points, simplices):
    """Barycentric gradients (E, k+1, dim) and volumes (E,) of simplices.

    Degenerate simplices (volume below a relative tolerance) get volume NaN and zero
    gradients, for the caller to report.
    """
    X = points[simplices]
    Ed = X[:, 1:, :] - X[:, :1, :]  # (E, k, dim)
    gram = Ed @ Ed.transpose(0, 2, 1)  # (E, k, k)
    k = Ed.shape[1]
    det = np.linalg.det(gram)
    scale = np.einsum("eij,eij->e", Ed, Ed) / k  # mean squared edge length from x0
    bad = ~(det > (_DEGENERATE_RTOL * scale) ** k)
    gram[bad] = np.eye(k)
    vol = np.sqrt(np.where(bad, 1.0, det)) / factorial(k)
    vol[bad] = np.nan
    rest = np.linalg.inv(gram) @ Ed  # (E, k, dim): row i is grad of barycentric coordinate i+1
    rest[bad] = 0.0
    grads = np.concatenate([-rest.sum(axis=1, keepdims=True), rest], axis=1)
    return grads, vol


class SimplicialComplex(Domain):
    """A pure simplicial complex of k-simplices with vertices in R^dim, 1 <= k <= dim.

    Parameters
    ----------
    points : array-like of shape (n_vertices, dim)
        Vertex coordinates. Copied.
    simplices : array-like of int of shape (n_elements, k + 1)
        Vertex indices of each simplex. Copied.

    Raises
    ------
    ValueError
        On NaN or infinite coordinates, out-of-range indices, a simplex with a
        repeated vertex or with zero volume, or more simplex vertices than
        ``dim + 1``.
    TypeError
        On non-numeric points or non-integer indices.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import SimplicialComplex
    >>> tri = SimplicialComplex([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> float(tri.A[0])
    0.5
    >>> tri.gradient([0.0, 1.0, 0.0]).tolist()
    [[1.0, 0.0]]
    """

    def __init__(self, points, simplices):
        self.points = check_points(points)
        self.simplices = check_cells(simplices, self.points.shape[0], name="simplices")
        k1 = self.simplices.shape[1]
        if k1 < 2:
            raise ValueError(
                f"simplices has shape {self.simplices.shape}; a simplex needs at least 2 vertices"
            )
        if k1 > self.dim + 1:
            raise ValueError(
                f"simplices has shape {self.simplices.shape} but points are {self.dim}-dimensional; "
                f"expected at most {self.dim + 1} vertices per simplex"
            )
        self._bary_grads, self._volumes = self._geometry()

    @classmethod
    def from_delaunay(cls, points):
        """The Delaunay triangulation of data points (scipy's Qhull), flat slivers dropped.

        Practical up to about 6 dimensions; beyond, use :class:`~ndboundary.PointCloud`.
        See :func:`ndboundary.delaunay_complex`.
        """
        from .pointcloud import delaunay_complex

        return delaunay_complex(points)

    # -- sizes -------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return int(self.simplices.shape[0])

    @property
    def simplex_dim(self) -> int:
        """The dimension k of the simplices (2 for triangles, 3 for tetrahedra)."""
        return int(self.simplices.shape[1] - 1)

    @property
    def element_dim(self) -> int:
        return self.simplex_dim

    # -- geometry ------------------------------------------------------------------
    def _geometry(self):
        """Barycentric gradients (E, k+1, dim) and volumes (E,), refusing degenerate simplices."""
        grads, vol = _simplex_geometry(self.points, self.simplices)
        bad = ~np.isfinite(vol)
        if bad.any():
            e = int(np.flatnonzero(bad)[0])
            k = self.simplex_dim
            raise ValueError(
                f"simplex {e} (vertices {self.simplices[e].tolist()}) is degenerate: zero "
                f"{'length' if k == 1 else 'area' if k == 2 else 'volume'}"
                f"{'' if bad.sum() == 1 else f' ({int(bad.sum())} degenerate simplices in all)'}"
            )
        return grads, vol

    def element_centroids(self) -> np.ndarray:
        return self.points[self.simplices].mean(axis=1)

    # -- operators ------------------------------------------------------------------
    def _build_gradient(self):
        E, k1 = self.simplices.shape
        D = self.dim
        rows = (np.arange(E)[:, None, None] * D + np.arange(D)[None, None, :]).repeat(k1, axis=1)
        cols = np.broadcast_to(self.simplices[:, :, None], (E, k1, D))
        return sp.csr_matrix(
            (self._bary_grads.ravel(), (rows.ravel(), cols.ravel())), shape=(E * D, self.n_vertices)
        )

    def _build_measures(self):
        return self._volumes.copy()

    def _build_stiffness(self):
        local = np.einsum("eid,ejd->eij", self._bary_grads, self._bary_grads) * self._volumes[:, None, None]
        k1 = self.simplices.shape[1]
        rows = np.repeat(self.simplices, k1, axis=1)
        cols = np.tile(self.simplices, (1, k1))
        K = sp.csr_matrix(
            (local.ravel(), (rows.ravel(), cols.ravel())), shape=(self.n_vertices, self.n_vertices)
        )
        return (K + K.T) * 0.5

    def _build_mass(self):
        k1 = self.simplices.shape[1]
        m = np.bincount(
            self.simplices.ravel(), weights=np.repeat(self._volumes / k1, k1), minlength=self.n_vertices
        )
        unused = m <= 0
        if unused.any():
            # Vertices in no simplex carry no measure; give them a tiny one so M stays invertible.
            m[unused] = self._volumes.mean() / k1 * 1e-12
        return m

    def _build_incidence(self):
        E, k1 = self.simplices.shape
        return sp.csr_matrix(
            (np.ones(E * k1), (self.simplices.ravel(), np.repeat(np.arange(E), k1))),
            shape=(self.n_vertices, E),
        )

    @cached_property
    def _facets(self):
        """Sorted facets of every simplex (element-major, (E*(k+1), k)) and their group ids."""
        E, k1 = self.simplices.shape
        srt = np.sort(self.simplices, axis=1)
        facets = np.stack([np.delete(srt, i, axis=1) for i in range(k1)], axis=1).reshape(E * k1, k1 - 1)
        ids, _ = group_rows(facets)
        return facets, ids

    def _build_adjacency(self):
        E, k1 = self.simplices.shape
        return shared_facet_adjacency(self._facets[1], np.repeat(np.arange(E), k1), E)

    def _build_edges(self):
        k1 = self.simplices.shape[1]
        i, j = np.triu_indices(k1, 1)
        a, b = self.simplices[:, i].ravel(), self.simplices[:, j].ravel()
        key = np.unique(np.minimum(a, b) * self.n_vertices + np.maximum(a, b))
        return np.stack([key // self.n_vertices, key % self.n_vertices], axis=1)

    def _interface_facets(self, region1):
        """Facets shared by a region-0 and a region-1 simplex: the jagged boundary, (n, k)."""
        facets, ids = self._facets
        k1 = self.simplices.shape[1]
        return facets[mixed_facets(ids, np.repeat(np.arange(self.n_elements), k1), region1)]

    def _split_elements(self, mask):
        mask = np.asarray(mask, dtype=bool)
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return self, np.arange(self.n_elements)
        k1 = self.simplices.shape[1]
        V = self.n_vertices
        centres = self.points[self.simplices[idx]].mean(axis=1)
        new_ids = V + np.arange(idx.size)
        parts = []
        for i in range(k1):
            s = self.simplices[idx].copy()
            s[:, i] = new_ids
            parts.append(s)
        new = np.concatenate(parts)
        parent = np.concatenate([np.flatnonzero(~mask)] + [idx] * k1)
        # children of valid simplices are valid: skip validation, and compute the geometry
        # of the new simplices only
        out = SimplicialComplex.__new__(SimplicialComplex)
        out.points = np.concatenate([self.points, centres])
        out.simplices = np.concatenate([self.simplices[~mask], new])
        grads, vols = _simplex_geometry(out.points, new)
        out._bary_grads = np.concatenate([self._bary_grads[~mask], grads])
        out._volumes = np.concatenate([self._volumes[~mask], vols])
        return out, parent

    def _level_set_simplices(self):
        return self.simplices

    def __repr__(self):
        return (
            f"SimplicialComplex(n_vertices={self.n_vertices}, n_elements={self.n_elements}, "
            f"simplex_dim={self.simplex_dim}, dim={self.dim})"
        )
