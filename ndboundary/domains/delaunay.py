"""Delaunay complexes of data points, and vertex functions on them evaluated at new points.

A :class:`DelaunayComplex` is the :class:`~ndboundary.SimplicialComplex` of the
Delaunay triangulation of distinct points (scipy's Qhull), flat slivers dropped. New
points get a function's value by barycentric interpolation in the containing simplex
and, outside the convex hull, by the first-order extension from the nearest vertex with
its measure-weighted gradient (:class:`SimplexExtension`).
"""

from __future__ import annotations

from math import factorial, sqrt

import numpy as np

from .._validation import check_points
from .simplicial import SimplicialComplex

__all__ = ["DELAUNAY_MAX_DIM", "DELAUNAY_MAX_POINTS", "DelaunayComplex", "SimplexExtension", "delaunay_complex"]

#: Delaunay complexes are refused beyond these sizes (Qhull's practical range).
DELAUNAY_MAX_DIM = 6
DELAUNAY_MAX_POINTS = {2: 2_000_000, 3: 500_000, 4: 50_000, 5: 10_000, 6: 3_000}
_ALTERNATIVE = "use the kNN alternative, ndboundary.PointCloud(points, n_neighbors=...)"


def _triangulate(points, rtol):
    """Qhull's triangulation of ``points`` and its simplices, slivers dropped, or a ValueError
    naming the kNN alternative.
    """
    pts = check_points(points, min_dim=2)
    n, dim = pts.shape
    if dim > DELAUNAY_MAX_DIM:
        raise ValueError(
            f"points are {dim}-dimensional; Delaunay complexes are practical up to "
            f"{DELAUNAY_MAX_DIM} dimensions: {_ALTERNATIVE}"
        )
    if n > DELAUNAY_MAX_POINTS[dim]:
        raise ValueError(
            f"{n} points in {dim} dimensions exceed what Qhull triangulates in reasonable time "
            f"and memory (at most {DELAUNAY_MAX_POINTS[dim]}): {_ALTERNATIVE}"
        )
    uniq = np.unique(pts, axis=0).shape[0]
    if uniq < n:
        raise ValueError(f"points contain {n - uniq} duplicate row(s); Delaunay needs distinct points: {_ALTERNATIVE}")
    from scipy.spatial import Delaunay, QhullError

    try:
        tri = Delaunay(pts)
    except QhullError as exc:
        raise ValueError(
            f"Qhull could not triangulate the {n} points (they may lie in a lower-dimensional "
            f"subspace): {str(exc).splitlines()[0]}; {_ALTERNATIVE}"
        ) from None
    simplices = tri.simplices.astype(np.int64)
    X = pts[simplices]
    E = X[:, 1:, :] - X[:, :1, :]
    det = np.abs(np.linalg.det(E))
    edges = np.linalg.norm(E, axis=2).mean()
    regular = sqrt(dim + 1) / (factorial(dim) * 2 ** (dim / 2)) * edges**dim * factorial(dim)
    simplices = simplices[det > rtol * regular]
    used = np.zeros(n, dtype=bool)
    used[simplices.ravel()] = True
    if not used.all():
        raise ValueError(
            f"{int((~used).sum())} point(s) (first: row {int(np.flatnonzero(~used)[0])}) lie in no "
            f"non-degenerate Delaunay simplex; {_ALTERNATIVE}"
        )
    return pts, tri, simplices


class DelaunayComplex(SimplicialComplex):
    """The Delaunay triangulation of data points, as a simplicial complex.

    Parameters
    ----------
    points : array-like of shape (n_points, dim)
        Distinct points, ``2 <= dim <= 6``. Copied.
    rtol : float, default=1e-10
        Simplices whose volume is below ``rtol`` times that of a regular simplex
        of the mean edge length (Qhull's flat slivers) are dropped.

    Attributes
    ----------
    triangulation : scipy.spatial.Delaunay
        Qhull's triangulation, which locates new points.

    Raises
    ------
    ValueError
        Beyond Qhull's practical range (dimension above 6, or too many points for the
        dimension), on duplicate points, on points Qhull leaves out of every simplex,
        or on fewer than ``dim + 1`` affinely independent points. The message names
        the kNN alternative, :class:`~ndboundary.PointCloud`.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import DelaunayComplex
    >>> X = np.random.default_rng(0).uniform(size=(50, 2))
    >>> dc = DelaunayComplex(X)
    >>> dc.simplex_dim, dc.n_vertices
    (2, 50)
    """

    def __init__(self, points, *, rtol=1e-10):
        pts, self.triangulation, simplices = _triangulate(points, rtol)
        super().__init__(pts, simplices)

    def extension(self, phi, **options):
        """Barycentric interpolation of ``phi`` at new points: a :class:`SimplexExtension`.

        The options of other domains' extensions (neighbours, power) do not apply.
        """
        return SimplexExtension(self, phi)

    def __repr__(self):
        return f"DelaunayComplex(n_vertices={self.n_vertices}, n_elements={self.n_elements}, dim={self.dim})"


def delaunay_complex(points, *, rtol=1e-10):
    """The Delaunay triangulation of data points: ``DelaunayComplex(points, rtol=rtol)``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import delaunay_complex
    >>> delaunay_complex(np.random.default_rng(0).uniform(size=(20, 3))).simplex_dim
    3
    """
    return DelaunayComplex(points, rtol=rtol)


class SimplexExtension:
    """Vertex functions of a Delaunay complex evaluated at new points.

    Inside the convex hull, barycentric interpolation in the containing Qhull simplex;
    outside, ``phi_j + grad phi_j . (x - x_j)`` from the nearest vertex ``j``, with the
    measure-weighted mean of the gradients of its simplices.

    Parameters
    ----------
    complex_ : DelaunayComplex
    phi : ndarray of shape (n_vertices, n_functions)

    Attributes
    ----------
    power : None
        No weighting power (it belongs to the kNN extension).

    Examples
    --------
    A linear function is reproduced inside the hull and extrapolated outside:

    >>> import numpy as np
    >>> from ndboundary import DelaunayComplex
    >>> X = np.random.default_rng(0).uniform(size=(50, 2))
    >>> ext = DelaunayComplex(X).extension(X.sum(axis=1))
    >>> ext(np.array([[0.5, 0.5], [2.0, 0.0]])).round(6).tolist()
    [[1.0], [2.0]]
    """

    power = None

    def __init__(self, complex_, phi):
        from sklearn.neighbors import NearestNeighbors

        self.complex = complex_
        self.phi = np.asarray(phi, dtype=np.float64).reshape(complex_.n_vertices, -1)
        self._nn_vertices = NearestNeighbors(n_neighbors=2).fit(complex_.points)
        inc = complex_.incidence.multiply(complex_.A[None, :]).tocsr()
        wsum = np.asarray(inc.sum(axis=1)).ravel()
        self._grad_v = np.stack(
            [np.asarray(inc @ complex_.gradient(p)) / wsum[:, None] for p in self.phi.T], axis=1
        )  # (n, r, D)

    def __call__(self, X, transform=None):
        """The functions at the points ``X`` (n, dim), or at ``transform(X)``: shape (n,
        n_functions).
        """
        X = np.asarray(X, dtype=np.float64) if transform is None else transform(X)
        return self._evaluate(X, self.complex.triangulation.find_simplex(X), nearest=0)

    def leave_one_out(self, rows):
        """The extension at the vertices ``rows`` from their nearest other vertex."""
        X = self.complex.points[np.asarray(rows)]
        return self._evaluate(X, np.full(X.shape[0], -1), nearest=1)

    def _evaluate(self, X, simplex, nearest):
        tri = self.complex.triangulation
        out = np.empty((X.shape[0], self.phi.shape[1]))
        inside = simplex >= 0
        if inside.any():
            s = simplex[inside]
            T = tri.transform[s]
            b = np.einsum("nij,nj->ni", T[:, :-1, :], X[inside] - T[:, -1, :])
            bary = np.concatenate([b, 1.0 - b.sum(axis=1, keepdims=True)], axis=1)
            out[inside] = np.einsum("nv,nvr->nr", bary, self.phi[tri.simplices[s]])
        rest = np.flatnonzero(~inside)
        if rest.size:
            _, ind = self._nn_vertices.kneighbors(X[rest], n_neighbors=2)
            j = ind[:, nearest]
            out[rest] = self.phi[j] + np.einsum("nrd,nd->nr", self._grad_v[j], X[rest] - self.complex.points[j])
        return out
