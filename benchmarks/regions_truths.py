"""The exact truths of ``benchmarks/regions.py``: Voronoi diagrams clipped to a box, a Y of
circular arcs meeting at 120 degrees, and a sphere cut by three planes.

Each truth labels points (element centroids) by the region they lie in and measures the
distance of points to its interfaces and junctions exactly (up to rounding); ``match``
pairs found junctions with true ones both ways.
"""

from __future__ import annotations

from functools import cached_property
from itertools import combinations

import numpy as np

from ndboundary.partition import partition


def _segment_distance(x, p, q):
    """Distance from every row of ``x`` to the segment ``pq`` (any dimension)."""
    d = q - p
    t = np.clip((x - p) @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
    return np.linalg.norm(x - p - t[:, None] * d, axis=1)


def _clip_polygon(poly, a, b):
    """Sutherland-Hodgman: the convex polygon ``poly`` (k, 2) cut to ``a . t <= b``."""
    out = []
    for i in range(len(poly)):
        p, q = poly[i], poly[(i + 1) % len(poly)]
        fp, fq = a @ p - b, a @ q - b
        if fp <= 0:
            out.append(p)
        if fp * fq < 0:
            out.append(p + fp / (fp - fq) * (q - p))
    return np.array(out).reshape(-1, 2)


def match(found, found_sets, true, true_sets):
    """Each true junction's distance to the nearest found one of compatible regions (one
    set inside the other), and each found one's to the nearest true one."""
    d = np.linalg.norm(true[:, None, :] - found[None], axis=2) if len(found) and len(true) else None
    t2f = np.full(len(true), np.inf)
    f2t = np.full(len(found), np.inf)
    if d is not None:
        ok = np.array([[a <= b or b <= a for b in found_sets] for a in true_sets])
        t2f = np.where(ok, d, np.inf).min(axis=1)
        f2t = d.min(axis=0)
    return t2f, f2t


class VoronoiTruth:
    """The Voronoi diagram of ``sites`` clipped to the box ``[lo, hi]^dim`` (dim 2 or 3).

    The face of a set S of sites (a facet for two, an edge for three in 3-D, a vertex for
    three in 2-D) is the part of the box equidistant from S and no nearer any other site:
    an affine subspace ``p + U t`` cut by linear constraints ``A t <= b``.
    """

    def __init__(self, sites, lo=-1.0, hi=1.0):
        self.sites = np.asarray(sites, dtype=np.float64)
        self.lo, self.hi = lo, hi
        self.dim = self.sites.shape[1]
        self._faces = {}

    def labels(self, x):
        return np.argmin(((x[:, None, :] - self.sites[None]) ** 2).sum(axis=2), axis=1)

    def exact_measures(self, mesh):
        """Region measures of the exact diagram on the mesh's simplicial refinement: the
        partition by the linear functions ``2 x . s - |s|^2``."""
        points, simplices, _ = mesh.level_set_complex(np.zeros(mesh.n_vertices))
        s = self.sites
        return partition(points, simplices, 2 * points @ s.T - (s**2).sum(axis=1)).region_measures()

    def face(self, S):
        """The face of the sites ``S`` as ``(p, U, vertices)`` (vertices in the plane
        coordinates ``t``: a point, an interval's ends or a ccw polygon), or None if empty."""
        S = tuple(sorted(int(i) for i in S))
        if S not in self._faces:
            self._faces[S] = self._build_face(S)
        return self._faces[S]

    def _build_face(self, S):
        s = self.sites
        a = s[S[0]]
        G = 2 * (s[list(S[1:])] - a)
        g = (s[list(S[1:])] ** 2).sum(axis=1) - a @ a
        p = np.linalg.pinv(G) @ g
        U = np.linalg.svd(G)[2][G.shape[0] :].T  # orthonormal basis of the null space, (D, m)
        others = s[[i for i in range(len(s)) if i not in S]]
        A = np.concatenate([2 * (others - a) @ U, U, -U])
        b = np.concatenate([(others**2).sum(axis=1) - a @ a - 2 * (others - a) @ p, self.hi - p, p - self.lo])
        m, tol = U.shape[1], 1e-12
        if m == 0:
            return (p, U, np.zeros((1, 0))) if np.all(b >= -tol) else None
        if m == 1:
            A = A[:, 0]
            up, down = A > tol, A < -tol
            if np.any(b[~up & ~down] < -tol):
                return None
            t0, t1 = (b[down] / A[down]).max(), (b[up] / A[up]).min()
            return (p, U, np.array([[t0], [t1]])) if t1 > t0 + tol else None
        poly = 10.0 * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
        for ai, bi in zip(A, b, strict=True):
            poly = _clip_polygon(poly, ai, bi)
            if len(poly) < 3:
                return None
        return p, U, poly

    def face_points(self, S):
        """The vertices of the face of ``S`` in space (a point, a segment's ends, a polygon)."""
        p, U, t = self.face(S)
        return p + t @ U.T

    def face_distance(self, x, S):
        """Distance from every row of ``x`` to the face of ``S`` (inf where it is empty)."""
        f = self.face(S)
        if f is None:
            return np.full(len(x), np.inf)
        p, U, T = f
        if T.shape[1] < 2:
            ends = p + T @ U.T
            return np.linalg.norm(x - ends[0], axis=1) if len(ends) == 1 else _segment_distance(x, ends[0], ends[1])
        t = (x - p) @ U
        off = np.linalg.norm(x - p - t @ U.T, axis=1)
        edges = np.roll(T, -1, axis=0) - T
        rel = t[:, None, :] - T[None]
        cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
        inside = np.all(cross >= 0, axis=1)
        ring = np.min([_segment_distance(t, T[i], T[(i + 1) % len(T)]) for i in range(len(T))], axis=0)
        return np.hypot(off, np.where(inside, 0.0, ring))

    def boundary_distance(self, x, r):
        """Distance to region ``r``'s boundary among the regions (not the box)."""
        return np.min([self.face_distance(x, (r, c)) for c in range(len(self.sites)) if c != r], axis=0)

    def interface_distance(self, x, a, b):
        """Distance to the true interface of sites ``a`` and ``b``; where they do not touch,
        the larger of the distances to either region's boundary."""
        if self.face((a, b)) is not None:
            return self.face_distance(x, (a, b))
        return np.maximum(self.boundary_distance(x, a), self.boundary_distance(x, b))

    @cached_property
    def triples(self):
        """The triples of sites with a non-empty face (2-D: a Voronoi vertex inside the box,
        3-D: a Voronoi edge crossing the box)."""
        return [S for S in combinations(range(len(self.sites)), 3) if self.face(S) is not None]

    def vertices_scipy(self):
        """2-D: the Voronoi vertices inside the box whose three nearest sites are
        equidistant, from :class:`scipy.spatial.Voronoi`, with their triples."""
        from scipy.spatial import Voronoi

        v = Voronoi(self.sites).vertices
        v = v[np.all((v >= self.lo) & (v <= self.hi), axis=1)]
        d = np.linalg.norm(v[:, None, :] - self.sites[None], axis=2)
        near = np.sort(d, axis=1)[:, :4]
        keep = (near[:, 2] - near[:, 0] < 1e-9 * (1 + near[:, 0])) & (near[:, 3] - near[:, 2] > 1e-9)
        return v[keep], np.sort(np.argsort(d, axis=1)[keep, :3], axis=1)

    def gap_midpoint_measures(self, sites, labels, reach):
        """2-D: the relative error of each region's area (a fraction, shape (n_sites,))
        when each true interface is kept along its true line and moved to the middle of
        the gap its labelled ``sites`` leave (those of its pair within ``reach`` of it):
        given the truth's directions and junctions, the best estimate of each interface's
        place under a flat prior. It bounds what any fit to the same labels reaches.
        """
        s, moved = self.sites, np.zeros(len(self.sites))
        for a, b in combinations(range(len(s)), 2):
            if self.face((a, b)) is None:
                continue
            ends = self.face_points((a, b))
            n = (s[b] - s[a]) / np.linalg.norm(s[b] - s[a])
            near = self.face_distance(sites, (a, b)) < reach
            on_a, on_b = sites[near & (labels == a)] @ n, sites[near & (labels == b)] @ n
            if on_a.size and on_b.size:
                shift = 0.5 * (on_a.max() + on_b.min()) - n @ (s[a] + s[b]) / 2  # towards b
                length = np.linalg.norm(ends[1] - ends[0])
                moved[a] += shift * length
                moved[b] -= shift * length
        return moved

    def junction_distance(self, x, regions):
        """Distance from ``x`` to the true junction (edge / vertex) of any triple in
        ``regions``; None where no such triple has one (the caller falls back)."""
        triples = [S for S in combinations(sorted(regions), 3) if self.face(S) is not None]
        if not triples:
            return None
        return np.min([self.face_distance(x, S) for S in triples], axis=0)


class YTruth:
    """Three regions meeting at ``centre``: region k lies between arcs k and k + 1 (ccw).

    Arc k leaves the centre along the angle ``angles[k]`` and bends with signed curvature
    ``curvatures[k]``; it is the circle through the centre tangent to that direction, and
    in polar coordinates about the centre its angle at radius rho is
    ``angles[k] + arcsin(kappa rho / 2)`` (the chord's angle from the tangent), one point
    per rho, so the labels below define the regions by the arcs exactly.
    """

    def __init__(self, centre=(0.07, -0.04), angles=(90.0, 210.0, 330.0), curvatures=(0.5, -0.4, 1 / 3)):
        self.centre = np.asarray(centre, dtype=np.float64)
        self.angles = np.radians(angles)
        self.kappa = np.asarray(curvatures, dtype=np.float64)
        t = np.stack([np.cos(self.angles), np.sin(self.angles)], axis=1)
        n = np.stack([-t[:, 1], t[:, 0]], axis=1)
        self.circle_centres = self.centre + n / self.kappa[:, None]

    def arc_angles(self, rho):
        """Angle of each arc at the distances ``rho`` from the centre, shape (n, 3)."""
        return self.angles[None] + np.arcsin(np.clip(self.kappa[None] * rho[:, None] / 2, -1, 1))

    def labels(self, x):
        d = x - self.centre
        rho = np.linalg.norm(d, axis=1)
        theta = self.arc_angles(rho)
        rel = (np.arctan2(d[:, 1], d[:, 0]) - theta[:, 0]) % (2 * np.pi)
        b1, b2 = (theta[:, 1] - theta[:, 0]) % (2 * np.pi), (theta[:, 2] - theta[:, 0]) % (2 * np.pi)
        return np.where(rel < b1, 0, np.where(rel < b2, 1, 2))

    @staticmethod
    def arc_of(a, b):
        """The arc between regions ``a`` and ``b``: arc k separates regions k - 1 and k."""
        return {(0, 1): 1, (1, 2): 2, (0, 2): 0}[(min(a, b), max(a, b))]

    def arc_distance(self, x, k):
        return np.abs(np.linalg.norm(x - self.circle_centres[k], axis=1) - 1 / abs(self.kappa[k]))

    def arc_points(self, k, rho):
        theta = self.arc_angles(rho)[:, k]
        return self.centre + rho[:, None] * np.stack([np.cos(theta), np.sin(theta)], axis=1)


def direction_angle(points, origin, r0, r1):
    """The angle (radians) of the direction a curve leaves ``origin`` along: the principal
    axis of its ``points`` between ``r0`` and ``r1`` of it (a line fit, which does not
    depend on where ``origin`` is across the curve), oriented away from ``origin``; None
    if there are fewer than two."""
    d = points - origin
    rho = np.linalg.norm(d, axis=1)
    keep = (rho >= r0) & (rho <= r1)
    if keep.sum() < 2:
        return None
    x = points[keep] - points[keep].mean(axis=0)
    u = np.linalg.svd(x, full_matrices=False)[2][0]
    u = u if u @ d[keep].mean(axis=0) > 0 else -u
    return np.arctan2(u[1], u[0])


def angles_between(angles):
    """The angles (degrees) between consecutive directions sorted ccw: they sum to 360."""
    a = np.sort(np.degrees(np.asarray(angles)) % 360)
    return np.diff(np.append(a, a[0] + 360))


class PlaneCuts:
    """The unit sphere cut by planes ``normals[i] . x = offsets[i]``: a point's region code
    is the bit pattern of the planes it lies above. Interfaces are arcs of the circles
    plane ∩ sphere; two planes cross on the sphere at up to two points where four regions
    meet (an X, not a triple junction)."""

    def __init__(self, normals, offsets):
        n = np.asarray(normals, dtype=np.float64)
        self.normals = n / np.linalg.norm(n, axis=1, keepdims=True)
        self.offsets = np.asarray(offsets, dtype=np.float64)

    def labels(self, x):
        above = (x @ self.normals.T - self.offsets) > 0
        return (above * (1 << np.arange(len(self.offsets)))).sum(axis=1)

    @cached_property
    def crossings(self):
        """``(points, codes)``: where two planes cross on the sphere, and the four codes there."""
        pts, codes = [], []
        for i, j in combinations(range(len(self.offsets)), 2):
            ni, nj = self.normals[i], self.normals[j]
            u = np.cross(ni, nj)
            p = np.linalg.lstsq(np.stack([ni, nj]), self.offsets[[i, j]], rcond=None)[0]  # nearest the origin
            u /= np.linalg.norm(u)
            disc = 1 - p @ p
            for sgn in (-1, 1) if disc > 0 else ():
                x = p + sgn * np.sqrt(disc) * u
                base = int(self.labels(x[None])[0]) & ~(1 << i) & ~(1 << j)
                pts.append(x)
                codes.append({base, base | 1 << i, base | 1 << j, base | 1 << i | 1 << j})
        return np.array(pts), codes

    def interface_distance(self, x, a, b):
        """Distance (tangential: ``|n . x - d|``) to the plane of the codes ``a`` and ``b``
        differing in one bit; for codes differing in more, the distance to the nearest
        crossing where both meet (they touch only there)."""
        bits = np.flatnonzero([(a ^ b) >> i & 1 for i in range(len(self.offsets))])
        if bits.size == 1:
            i = int(bits[0])
            return np.abs(x @ self.normals[i] - self.offsets[i])
        pts, codes = self.crossings
        at = [p for p, c in zip(pts, codes, strict=True) if {a, b} <= c]
        if not at:
            return np.full(len(x), np.inf)
        return np.min(np.linalg.norm(x[:, None, :] - np.array(at)[None], axis=2), axis=1)
