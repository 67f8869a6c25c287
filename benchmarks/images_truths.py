"""The exact truths and the peers of ``benchmarks/images.py``.

Truths, each with ``inside(x)`` (voxelised by voxel centre), an unsigned ``distance(x)``
to the true boundary, and the true ``volume`` and ``area`` (2-D: area and length):

- :class:`Ball`: ``| |x - c| - R |``, ``4/3 pi R^3``, ``4 pi R^2``.
- :class:`Torus` (tilted): ``| hypot(rho - R, z) - r |`` in the torus' frame,
  ``2 pi^2 R r^2``, ``4 pi^2 R r``.
- :class:`StarShape`: ``|x - c| < R (1 + sum_k a_k P_k(u))``, ``u = (x - c) / |x - c|``,
  with ``P_k`` low-order spherical harmonics written as polynomials in ``u`` (the blob) or
  ``cos(lobes theta)`` (the 2-D flower). Distance: the nearest of a dense sample of the
  surface, then refined to the foot point (``foot_distance``: Newton steps along the
  gradient of ``F(x) = |x - c| - r(u)`` onto ``F = 0``, alternated with projecting the
  point onto the tangent plane there, until the step is below 1e-10 voxel; the foot
  point's ``x - q`` is then parallel to the normal). Volume and area by quadrature:
  Gauss-Legendre in theta (600 nodes) times the trapezoid rule in phi (1200 nodes), of
  ``r^3 sin(theta) / 3`` and ``|S_theta x S_phi|`` (central differences of the
  parametrisation ``S``, step 1e-6); in 2-D the trapezoid rule (20 000 nodes) of
  ``r^2 / 2`` and ``sqrt(r^2 + r'^2)``: halving the 3-D nodes changes them by < 1e-11.
- :class:`YAreas`: the Y of ``regions_truths.YTruth`` in the image's box: each region's
  area (shoelace of centre - arc - box border - arc, the arcs sampled every 1e-4 of the
  box: exact to ~1e-9), each arc's exact length, the exact distance to a region's arcs.

Peers and staircase: see ``benchmarks/images.py`` (Slicer's: its ``Libs/vtkSegmentationCore``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ndboundary.metrics import as_complex

# --------------------------------------------------------------------------- truths


class Ball:
    def __init__(self, centre, R):
        self.c, self.R = np.asarray(centre, dtype=np.float64), float(R)
        self.volume, self.area = 4 / 3 * np.pi * self.R**3, 4 * np.pi * self.R**2

    def F(self, x):
        """The signed distance, negative inside."""
        return np.linalg.norm(x - self.c, axis=1) - self.R

    def inside(self, x):
        return self.F(x) < 0

    def distance(self, x):
        return np.abs(self.F(x))


class Torus:
    def __init__(self, centre, R, r, tilt=(0.3, 0.2)):
        self.c, self.R, self.r = np.asarray(centre, dtype=np.float64), float(R), float(r)
        (ca, sa), (cb, sb) = ((np.cos(t), np.sin(t)) for t in tilt)  # about x, then about y
        self.rot = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]]) @ np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
        self.volume, self.area = 2 * np.pi**2 * self.R * self.r**2, 4 * np.pi**2 * self.R * self.r

    def _signed(self, x):
        y = (x - self.c) @ self.rot  # into the torus' frame
        return np.hypot(np.hypot(y[:, 0], y[:, 1]) - self.R, y[:, 2]) - self.r

    def inside(self, x):
        return self._signed(x) < 0

    def distance(self, x):
        return np.abs(self._signed(x))


def foot_distance(F, p, q, scale, tol=1e-10, iters=60):
    """Distance from the points ``p`` to the surface ``F = 0``, from the starting points
    ``q`` on or near it (the nearest of a dense sample): Newton steps along the gradient
    onto ``F = 0`` alternated with the projection of ``p`` onto the tangent plane there.
    ``scale``: the voxel size (the gradient's step is ``1e-6 scale``)."""
    eps = 1e-6 * scale

    def grad(y):
        return np.stack([(F(y + eps * e) - F(y - eps * e)) / (2 * eps) for e in np.eye(p.shape[1])], axis=1)

    q = q.copy()
    active = np.ones(len(p), dtype=bool)
    for _ in range(iters):
        y = q[active]
        for _ in range(3):
            g = grad(y)
            y = y - (F(y) / np.maximum((g * g).sum(1), 1e-300))[:, None] * g
        n = grad(y)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        z = p[active] - ((p[active] - y) * n).sum(1)[:, None] * n
        for _ in range(3):
            g = grad(z)
            z = z - (F(z) / np.maximum((g * g).sum(1), 1e-300))[:, None] * g
        step = np.linalg.norm(z - q[active], axis=1)
        q[active] = z
        active[np.flatnonzero(active)[step < tol * scale]] = False
        if not active.any():
            break
    return np.linalg.norm(p - q, axis=1)


class StarShape:
    """``|x - c| < R (1 + perturb(u))``: the 3-D blob (``terms``: (coefficient, function of
    the unit vector u)) or the 2-D flower (``lobes``, ``amplitude``, ``phase``)."""

    def __init__(self, centre, R, terms=None, lobes=5, amplitude=0.2, phase=0.3, scale=1.0):
        self.c, self.R = np.asarray(centre, dtype=np.float64), float(R)
        self.dim, self.scale = self.c.size, scale
        self.terms, self.lobes, self.amplitude, self.phase = terms, lobes, amplitude, phase
        self.volume, self.area = self._quadrature()
        self.samples = self._surface(*self._dense())

    def radius(self, u):
        if self.dim == 2:
            th = np.arctan2(u[:, 1], u[:, 0])
            return self.R * (1 + self.amplitude * np.cos(self.lobes * (th - self.phase)))
        return self.R * (1 + sum(a * f(u) for a, f in self.terms))

    def F(self, x):
        d = x - self.c
        rho = np.linalg.norm(d, axis=1)
        return rho - self.radius(d / np.maximum(rho, 1e-300)[:, None])

    def inside(self, x):
        return self.F(x) < 0

    def _directions(self, th, ph=None):
        if self.dim == 2:
            return np.stack([np.cos(th), np.sin(th)], axis=-1)
        return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)

    def _surface(self, th, ph=None):
        u = self._directions(th, ph).reshape(-1, self.dim)
        return self.c + self.radius(u)[:, None] * u

    def _quadrature(self):
        if self.dim == 2:
            th = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
            h = 1e-6
            r = self.radius(self._directions(th))
            dr = (self.radius(self._directions(th + h)) - self.radius(self._directions(th - h))) / (2 * h)
            w = 2 * np.pi / th.size
            return float((r**2 / 2).sum() * w), float(np.sqrt(r**2 + dr**2).sum() * w)
        t, wt = np.polynomial.legendre.leggauss(600)
        th, wt = (t + 1) * np.pi / 2, wt * np.pi / 2
        ph = np.linspace(0, 2 * np.pi, 1200, endpoint=False)
        TH, PH = np.meshgrid(th, ph, indexing="ij")
        W = wt[:, None] * (2 * np.pi / ph.size)
        r = self.radius(self._directions(TH, PH).reshape(-1, 3)).reshape(TH.shape)
        h = 1e-6
        S = lambda a, b: self._surface(a, b).reshape(TH.shape + (3,))  # noqa: E731
        St = (S(TH + h, PH) - S(TH - h, PH)) / (2 * h)
        Sp = (S(TH, PH + h) - S(TH, PH - h)) / (2 * h)
        volume = (W * r**3 * np.sin(TH) / 3).sum()
        area = (W * np.linalg.norm(np.cross(St, Sp), axis=-1)).sum()
        return float(volume), float(area)

    def _dense(self, step=0.25):
        """Parameters of a sample of the surface about ``step`` voxels apart (or closer)."""
        rmax = self.R * 1.5
        if self.dim == 2:
            return (np.linspace(0, 2 * np.pi, int(2 * np.pi * rmax / (step * self.scale)), endpoint=False),)
        n = int(4 * np.pi * rmax**2 / (step * self.scale) ** 2)
        k = np.arange(n) + 0.5
        return np.arccos(1 - 2 * k / n), np.pi * (1 + 5**0.5) * k  # Fibonacci sphere

    def distance(self, x):
        tree = self.__dict__.setdefault("_tree", cKDTree(self.samples))
        d0, i = tree.query(x)
        return np.minimum(d0, foot_distance(self.F, x, self.samples[i], self.scale))


def blob_terms():
    """Low-order real spherical harmonics (l = 2, 3) as polynomials in the unit vector."""
    return [(0.10, lambda u: (3 * u[:, 2] ** 2 - 1) / 2), (0.08, lambda u: u[:, 0] ** 2 - u[:, 1] ** 2),
            (0.12, lambda u: u[:, 0] * u[:, 2] * 3), (0.25, lambda u: u[:, 0] * u[:, 1] * u[:, 2] * 5),
            (0.06, lambda u: u[:, 2] * (5 * u[:, 2] ** 2 - 3) / 2)]  # fmt: skip


class YAreas:
    """Exact areas, lengths and distances of the Y (``regions_truths.YTruth``) in ``[lo, hi]^2``."""

    def __init__(self, y, lo=-1.0, hi=1.0):
        self.y, self.lo, self.hi = y, lo, hi
        self.rho_exit = np.array([self._exit(k) for k in range(3)])
        self.lengths = 2 / np.abs(y.kappa) * np.arcsin(np.abs(y.kappa) * self.rho_exit / 2)
        self.areas = np.array([self._area(k) for k in range(3)])

    def _exit(self, k):
        a, b = 0.0, 4.0 * (self.hi - self.lo)
        for _ in range(200):
            m = (a + b) / 2
            p = self.y.arc_points(k, np.array([m]))[0]
            a, b = (m, b) if np.all((p > self.lo) & (p < self.hi)) else (a, m)
        return a

    def _box_position(self, p):
        """Counter-clockwise arclength position along the box border from (lo, lo)."""
        L, (x, y) = self.hi - self.lo, p - self.lo
        if abs(y) < 1e-9:
            return x
        if abs(x - L) < 1e-9:
            return L + y
        if abs(y - L) < 1e-9:
            return 2 * L + (L - x)
        return 3 * L + (L - y)

    def _arc(self, k, n=None):
        n = n or int(self.rho_exit[k] / (1e-4 * (self.hi - self.lo))) + 2
        return self.y.arc_points(k, np.linspace(0.0, self.rho_exit[k], n))

    def _area(self, k):
        """Region k lies ccw between arcs k and k + 1 (mod 3)."""
        a, b = self._arc(k), self._arc((k + 1) % 3)
        L = self.hi - self.lo
        s0, s1 = self._box_position(a[-1]), self._box_position(b[-1])
        s1 = s1 if s1 > s0 else s1 + 4 * L
        corners = [c for c in np.arange(0, 9) * L if s0 < c < s1]
        box = [self._box_point(c % (4 * L)) for c in corners]
        poly = np.concatenate([a, np.array(box).reshape(-1, 2), b[::-1]])
        x, y = poly[:, 0], poly[:, 1]
        return abs(float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2)

    def _box_point(self, s):
        L = self.hi - self.lo
        side, t = int(s // L), s % L
        return self.lo + np.array([[t, 0], [L, t], [L - t, L], [0, L - t]][side], dtype=np.float64)

    def arc_distance(self, x, k):
        """Exact distance to arc k: to its circle where the nearest circle point lies on
        the arc, else to the nearer end."""
        y = self.y
        cc, rc = y.circle_centres[k], 1 / abs(y.kappa[k])
        d = x - cc
        q = cc + rc * d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
        rho = np.linalg.norm(q - y.centre, axis=1)
        on = (rho <= self.rho_exit[k]) & (np.linalg.norm(q - y.arc_points(k, rho), axis=1) < 1e-9)
        ends = self._arc(k, 2)
        d_end = np.minimum(np.linalg.norm(x - ends[0], axis=1), np.linalg.norm(x - ends[1], axis=1))
        return np.where(on, np.abs(np.linalg.norm(d, axis=1) - rc), d_end)

    def boundary_distance(self, x, r):
        return np.minimum(self.arc_distance(x, r), self.arc_distance(x, (r + 1) % 3))


# --------------------------------------------------------------------------- peers


def vtk_image(mask, spacing, origin):
    import vtk
    from vtk.util import numpy_support

    im = vtk.vtkImageData()
    shape = mask.shape + (1,) * (3 - mask.ndim)
    im.SetDimensions(*shape)
    im.SetSpacing(*(tuple(spacing) + (1.0,) * (3 - mask.ndim)))
    im.SetOrigin(*(tuple(origin) + (0.0,) * (3 - mask.ndim)))
    scalars = numpy_support.numpy_to_vtk(np.ascontiguousarray(mask.ravel(order="F")).astype(np.uint8), deep=1)
    im.GetPointData().SetScalars(scalars)
    return im


def vtk_cells(poly, dim):
    """``(points, simplices)`` of a vtkPolyData: triangles (3-D) or its 2-point lines (2-D)."""
    import vtk
    from vtk.util import numpy_support

    if poly.GetNumberOfPoints() == 0:
        return np.zeros((0, dim)), np.zeros((0, dim), dtype=np.int64)
    if dim == 3:
        tf = vtk.vtkTriangleFilter()
        tf.SetInputData(poly)
        tf.Update()
        poly = tf.GetOutput()
    cells = poly.GetPolys() if dim == 3 else poly.GetLines()
    points = numpy_support.vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)[:, :dim]
    return points, numpy_support.vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64).reshape(-1, dim)


def surface_nets(mask, spacing, origin):
    import vtk

    f = vtk.vtkSurfaceNets3D() if mask.ndim == 3 else vtk.vtkSurfaceNets2D()
    f.SetInputData(vtk_image(mask, spacing, origin))
    f.SetValue(0, 1)
    f.Update()
    return vtk_cells(f.GetOutput(), mask.ndim)


def surface_nets_partition(labels, spacing, origin):
    """VTK's ``vtkSurfaceNets3D`` on a label volume of values ``0 .. K - 1`` (``K <= 255``):
    every region's surface, with the interfaces between regions shared, in one pass."""
    import vtk

    f = vtk.vtkSurfaceNets3D()
    f.SetInputData(vtk_image(labels + 1, spacing, origin))  # 0 is VTK's background label
    for k in range(int(labels.max()) + 1):
        f.SetValue(k, k + 1)
    f.Update()
    return vtk_cells(f.GetOutput(), 3)


def slicer(mask, spacing, origin):
    import vtk

    fe = vtk.vtkDiscreteFlyingEdges3D()
    fe.SetInputData(vtk_image(mask, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)))  # IJK space, as Slicer
    fe.ComputeGradientsOff()
    fe.ComputeNormalsOff()
    fe.SetValue(0, 1)
    fe.Update()
    ws = vtk.vtkWindowedSincPolyDataFilter()
    ws.SetInputData(fe.GetOutput())
    ws.SetNumberOfIterations(20)
    ws.SetPassBand(10.0 ** (-4.0 * 0.5))
    ws.BoundarySmoothingOff()
    ws.FeatureEdgeSmoothingOff()
    ws.NonManifoldSmoothingOn()
    ws.NormalizeCoordinatesOn()
    ws.Update()
    points, tris = vtk_cells(ws.GetOutput(), 3)
    return np.asarray(origin) + points * np.asarray(spacing), tris


def skimage_contour(mask, spacing, origin, sigma=None):
    from scipy.ndimage import gaussian_filter
    from skimage.measure import find_contours, marching_cubes

    field = mask.astype(np.float64)
    if sigma is not None:
        field = gaussian_filter(field, sigma, mode="constant")
    if mask.ndim == 3:
        verts, faces, _, _ = marching_cubes(field, 0.5)
        return np.asarray(origin) + verts * np.asarray(spacing), faces.astype(np.int64)
    points, segs, n = [], [], 0
    for c in find_contours(field, 0.5):
        closed = np.allclose(c[0], c[-1])
        c = c[:-1] if closed else c
        idx = np.arange(len(c)) + n
        segs.append(np.stack([idx, np.roll(idx, -1)], 1) if closed else np.stack([idx[:-1], idx[1:]], 1))
        points.append(c)
        n += len(c)
    return np.asarray(origin) + np.concatenate(points) * np.asarray(spacing), np.concatenate(segs)


def staircase(mask, spacing, origin):
    """The voxel faces (2-D: pixel edges) between ``mask`` and the rest, padded so that
    they close: ``(points, triangles or segments)`` in physical coordinates."""
    P = np.pad(mask.astype(bool), 1)
    dim, cells = P.ndim, []
    for a in range(dim):
        lo = np.argwhere(np.diff(P, axis=a)) - 1  # the voxel below the face (original index)
        lo[:, a] += 1  # the face's corner index along a
        e = [np.eye(dim, dtype=np.int64)[b] for b in range(dim) if b != a]
        if dim == 2:
            cells.append(np.stack([lo, lo + e[0]], 1))
        else:
            cells += [np.stack([lo, lo + e[0], lo + e[0] + e[1]], 1), np.stack([lo, lo + e[0] + e[1], lo + e[1]], 1)]
    corners = np.concatenate(cells)
    uniq, inv = np.unique(corners.reshape(-1, dim), axis=0, return_inverse=True)
    points = np.asarray(origin) + (uniq - 0.5) * np.asarray(spacing)
    return points, inv.reshape(corners.shape[:2])


PEERS = {
    "skimage mask": lambda m, s, o: skimage_contour(m, s, o),
    "skimage gauss1": lambda m, s, o: skimage_contour(m, s, o, sigma=1.0),
    "vtk surfacenets": surface_nets,
    "slicer recipe": slicer,
}


def enclosed(points, simplices):
    """The measure enclosed by a closed surface (consistently oriented), or by closed
    curves (each chained into a loop by its own, their areas added: no holes)."""
    if simplices.shape[1] == 3:
        p = points[simplices]
        return abs(float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum()) / 6)
    nbr = {}
    for a, b in simplices.tolist():
        nbr.setdefault(a, []).append(b)
        nbr.setdefault(b, []).append(a)
    seen, total = set(), 0.0
    for start in nbr:
        if start in seen:
            continue
        loop, prev, cur = [start], None, start
        seen.add(start)
        while True:
            nxt = [v for v in nbr[cur] if v != prev]
            if not nxt or nxt[0] == start or nxt[0] in seen:
                break
            prev, cur = cur, nxt[0]
            loop.append(cur)
            seen.add(cur)
        x, y = points[loop, 0], points[loop, 1]
        total += abs(float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2)
    return total


def run_peer(name, mask, spacing, origin):
    """A peer's boundary of ``mask`` (padded by one background voxel, so that it closes)
    as a compact LevelSet, its enclosed measure and its seconds."""
    import time

    import skimage.measure  # noqa: F401  (imported before the clock starts)
    import vtk  # noqa: F401

    spacing = np.asarray(spacing, dtype=np.float64)
    padded = np.pad(mask.astype(np.uint8), 1)
    t0 = time.perf_counter()
    points, simplices = PEERS[name](padded, spacing, np.asarray(origin) - spacing)
    seconds = time.perf_counter() - t0
    if len(simplices) == 0:
        return None, np.nan, seconds
    return as_complex(points, simplices), enclosed(points, simplices), seconds
