"""Surfaces of two-region label volumes fitted to their voxels.

Each pair of voxels across the staircase says only that the boundary crosses the segment
between their centres, and the relaxation pins it at the segment's middle (weighted
towards the staircase's risers). Where the surface runs along a plane of the lattice (at
45 degrees between two axes, the planes of voxel centres lie 0.71 voxel apart), the
voxels leave it a gap that wide to stray in, and the pins place it anywhere in it. The
labels say more than each pair: the true surface parts the voxel centres, and it is
smooth. So the relaxed surface is moved along its normals to the surface that minimises

    BETA * integral |grad H|^2  +  sum(exp(-margin / tau))

over the voxel centres within :data:`SITE_REACH` h of it (lengths in h, the smallest
spacing): ``H`` its mean curvature (spheres and planes, moved, translated or scaled, cost
nothing), ``margin`` a centre's signed distance to it, positive on its label's side. It is
the surface counterpart of the curves' fit (:mod:`~ndboundary.pipeline.interface_fit`).

The surface is meshed as surface nets on phi (:func:`surface_mesh`): one vertex in each
voxel whose corners phi crosses, moved onto phi = 1/2, one quad about each voxel edge phi
crosses. Its quads are nearly squares of a voxel's side, as the cotangent operators need
(on the marching simplices' triangles, thin near the voxel corners, the discrete mean
curvature came out four times too large on average). ``H`` is linearised about the
relaxed surface, ``H0 + B z`` with ``B = (M^-1 K - |A|^2) / 2`` (``K`` the cotangent
stiffness, ``M`` the lumped mass, ``|A|^2 = 4 H^2 - 2 K_gauss``), and the loss minimised by
Newton steps from the relaxed surface, searched along their line (the loss is convex: the
curves' narrowing of the soft minimum's width from 0.1 ends at the same surface, in more
steps); the first system is solved by a sparse Cholesky factor, the next by conjugate
gradients preconditioned by it (:class:`_Preconditioned`).

A surface that turns sharper than :data:`CORNER` somewhere (a box's edges) is left as
relaxed, as a curve is. The moves are written into phi near the surface, ``phi - z (grad
phi . n)``, fully within :data:`CORE` voxels of it, blended out by :data:`BLEND`. The fit
moves the surface's shape, not its volume, which the relaxation's pins keep: the change
of volume that writing makes (to first order, the change of phi at the surface's vertices
over its slope, integrated over the surface) is undone by a uniform move of the surface.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..domains.voxels import CORNER_BITS
from ..solvers.cholesky import factorize_spd
from .interface_fit import margin_newton

__all__ = ["AUTO_MAX_VERTICES", "BETA", "CORNER", "SURFACE_FIT", "TAUS", "fit_surface", "surface_mesh"]

#: Whether a relaxation of a two-region label volume fits its surface to the voxels.
SURFACE_FIT = True
#: Weight of the prior on the change of mean curvature against the margins (lengths in h).
BETA = 1000.0
#: Widths (h) of the margins' soft minimum, in turn, each fit starting from the one before.
TAUS = (0.03,)
#: A connected surface whose largest principal curvature (1 / h, averaged over each
#: vertex's two rings) exceeds this somewhere has an edge or a corner, which a surface of
#: slowly changing curvature cannot follow: it is left as relaxed. Balls of radius 5 voxels
#: and more stay below it (0.30 at most); the relaxed edges of a box and a cylinder's rims
#: reach 0.39 to 0.43.
CORNER = 1.0 / 3.0
#: ``relax_image(fit="auto")`` fits a surface of up to about this many vertices (half as
#: many as the staircase has facets; the ball of 128³ voxels, of radius 41, has 32 000):
#: the fit's Cholesky factors grow faster than the surface.
AUTO_MAX_VERTICES = 60_000
#: The voxel centres within this many h of the surface are the ones it parts.
SITE_REACH = 2.0
#: The moves are written into phi fully within ``CORE`` voxels (their longest side) of the
#: surface's vertices, blended out by ``BLEND``.
CORE = 3.0
BLEND = 5.0
#: How many of the surface's vertices each vertex of the grid takes its move from.
SPREAD = 8
#: Newton steps stop when no vertex moves farther than this (h).
TOLERANCE = 1e-3
#: Newton systems after the first are solved by conjugate gradients to this relative
#: residual, preconditioned by the last Cholesky factor, which is made anew past this many steps.
CG_RTOL = 1e-3
CG_STEPS = 40
#: Newton steps per width of the soft minimum, at most.
ITERATIONS = 30


def surface_mesh(domain, phi, level=0.5):
    """Surface nets of ``phi == level`` on a voxel grid or band ``domain``: ``(points,
    faces, normals, slopes)``, the vertices (one per voxel whose corners phi crosses, moved
    onto the level set of phi trilinear in its voxel), the triangles (each crossed voxel
    edge's quad of its four voxels, split along its shorter diagonal; an edge with fewer of
    its voxels in the domain has none), the unit normals (towards decreasing phi) and
    ``|grad phi|`` at the vertices, all in the domain's coordinates.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.pipeline.surface_fit import surface_mesh
    >>> grid = ImageGrid((12, 12, 12))
    >>> phi = 0.5 + 4.0 - np.linalg.norm(grid.points - 5.5, axis=1)  # 1/2 on a sphere of radius 4
    >>> points, faces, normals, slopes = surface_mesh(grid, phi)
    >>> r = np.linalg.norm(points - 5.5, axis=1)
    >>> bool(np.abs(r - 4.0).max() < 0.1), bool((np.einsum("ij,ij->i", normals, points - 5.5) > 0).all())
    (True, True)
    """
    return _surface_mesh(domain, phi, level)[:4]


def _surface_mesh(domain, phi, level):
    """:func:`surface_mesh`, with each vertex's voxel's corners (vertex ids, shape (n, 8),
    :data:`CORNER_BITS` order) and their trilinear weights at the vertex.
    """
    corners = domain.cell_vertices[1].reshape(domain.n_elements, 8)
    f = np.asarray(phi, dtype=np.float64)[corners] - level
    above = f > 0
    cells = np.flatnonzero(above.any(axis=1) & ~above.all(axis=1))
    shape = np.asarray(domain.shape)
    voxel = np.stack(np.unravel_index(getattr(domain, "pixels", np.arange(domain.n_elements))[cells], tuple(shape)), 1)
    fc, bits = f[cells], CORNER_BITS
    total, count = np.zeros((cells.size, 3)), np.zeros(cells.size)
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.abs(bits[i] - bits[j]).sum() == 1]
    for i, j in edges:  # the mean of the crossings on the voxel's 12 edges, in its unit box
        cross = (fc[:, i] > 0) != (fc[:, j] > 0)
        t = np.where(cross, fc[:, i] / np.where(cross, fc[:, i] - fc[:, j], 1.0), 0.0)
        total += cross[:, None] * (bits[i] + t[:, None] * (bits[j] - bits[i]))
        count += cross
    local = total / count[:, None]
    for _ in range(8):  # Newton steps onto the trilinear phi's level set
        value, grad = _trilinear(fc, local)
        local = local - (value / np.maximum((grad * grad).sum(axis=1), 1e-300))[:, None] * grad
    _, grad = _trilinear(fc, local)
    # in the domain's coordinates: index u -> origin + direction (spacing (u - 1/2)) for the corners
    spacing = np.asarray(domain.spacing, dtype=np.float64)
    rotate = np.eye(3) if domain.direction is None else np.asarray(domain.direction)
    points = (spacing * (voxel + local - 0.5)) @ rotate.T + np.asarray(domain.origin, dtype=np.float64)
    grad = (grad / spacing) @ rotate.T
    slopes = np.linalg.norm(grad, axis=1)
    normals = -grad / slopes[:, None]
    faces = _quads(voxel, fc, shape, points)
    weights = np.stack([np.where(b, local, 1.0 - local).prod(axis=1) for b in CORNER_BITS], axis=1)
    return points, faces, normals, slopes, corners[cells], weights


def _trilinear(fc, x):
    """The trilinear interpolant of the corner values ``fc`` (n, 8; :data:`CORNER_BITS`
    order) at ``x`` (n, 3; each in its voxel's unit box) and its gradient.
    """
    value, grad = np.zeros(len(x)), np.zeros_like(x)
    for c, b in enumerate(CORNER_BITS):
        w = np.where(b, x, 1.0 - x)  # (n, 3)
        value += fc[:, c] * w.prod(axis=1)
        for a in range(3):
            others = np.prod(np.delete(w, a, axis=1), axis=1)
            grad[:, a] += fc[:, c] * (1.0 if b[a] else -1.0) * others
    return value, grad


def _quads(voxel, fc, shape, points):
    """The triangles of surface nets: about each voxel edge whose ends phi parts, the quad of
    the four voxels around it (all crossed), oriented with phi decreasing along its normal.
    """
    flat = np.ravel_multi_index(voxel.T, tuple(shape))
    order = np.argsort(flat)
    sorted_flat = flat[order]
    out = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        lo = np.flatnonzero((CORNER_BITS[:, b] == 1) & (CORNER_BITS[:, c] == 1) & (CORNER_BITS[:, a] == 0))[0]
        hi = np.flatnonzero((CORNER_BITS[:, b] == 1) & (CORNER_BITS[:, c] == 1) & (CORNER_BITS[:, a] == 1))[0]
        # each crossed edge once: from the voxel that holds it at its (b, c) = (1, 1) corner edge
        crossed = (fc[:, lo] > 0) != (fc[:, hi] > 0)
        base = voxel[crossed]
        ring = []
        for db, dc in ((0, 0), (1, 0), (1, 1), (0, 1)):
            v = base.copy()
            v[:, b] += db
            v[:, c] += dc
            within = (v[:, b] < shape[b]) & (v[:, c] < shape[c])
            want = np.ravel_multi_index(np.minimum(v, shape - 1).T, tuple(shape))
            at = np.minimum(np.searchsorted(sorted_flat, want), sorted_flat.size - 1)
            ring.append(np.where(within & (sorted_flat[at] == want), order[at], -1))
        q = np.stack(ring, axis=1)
        keep = (q >= 0).all(axis=1)
        q, up = q[keep], fc[crossed][keep, lo] > 0  # phi above the level at the edge's start
        q[~up] = q[~up][:, ::-1]
        out.append(q)
    q = np.concatenate(out)
    short = np.linalg.norm(points[q[:, 0]] - points[q[:, 2]], axis=1) <= np.linalg.norm(
        points[q[:, 1]] - points[q[:, 3]], axis=1
    )
    return np.where(short[:, None], q[:, [0, 1, 2, 0, 2, 3]], q[:, [0, 1, 3, 1, 2, 3]]).reshape(-1, 3)


def fit_surface(result, codes, max_vertices=None):
    """Fit the relaxed surface of ``result``, a relaxation of two regions of a voxel grid or
    band, to its voxels (``codes``: each voxel's region, 0 or 1), as the module describes,
    and write the fit into ``result.phi`` (a new array) near the surface, keeping the
    relaxed volume of region 1; whether any part of it was fitted. A surface of more than
    ``max_vertices`` vertices (None: any) is left as relaxed.
    """
    domain = result.domain
    if not SURFACE_FIT:
        return False
    facets = getattr(result.boundary, "facets", None)
    if max_vertices is not None and facets is not None and len(facets) > 2 * max_vertices:
        return False  # the mesh has about half as many vertices as the staircase has facets
    phi = np.array(result.phi, dtype=np.float64)
    h = float(np.min(domain.spacing))
    points, faces, normals, slopes, corner_ids, corner_weights = _surface_mesh(domain, phi, 0.5)
    if faces.shape[0] < 8 or (max_vertices is not None and points.shape[0] > max_vertices):
        return False
    curvatures = _curvatures(points / h, faces, normals)  # lengths in h
    keep = _smooth_components(curvatures)
    if not keep.any():
        return False
    sites = domain.element_centroids()
    tree = cKDTree(points)
    dist, near = tree.query(sites, distance_upper_bound=SITE_REACH * h)
    on = np.isfinite(dist) & keep[np.minimum(near, points.shape[0] - 1)]
    side = np.where(np.asarray(codes)[on] == 1, -1.0, 1.0)  # region 1 lies against the normals
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            z = _fit(points / h, normals, curvatures, sites[on] / h, near[on], side, keep)
    except (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError):
        return False
    if z is None:
        return False
    # written into phi near the surface: phi - z (grad phi . n) = phi + z |grad phi|, fully
    # within CORE voxels (their longest side, so that every edge the surface crosses moves
    # whole), each vertex of the grid taking the moves of the surface around its nearest
    # points, so that what varies from one of the surface's vertices to the next is not aliased
    unit = float(np.max(domain.spacing))
    candidates = np.flatnonzero(np.abs(phi - 0.5) < BLEND * unit * float(slopes.max()))
    d, at = tree.query(domain.points[candidates], k=SPREAD, distance_upper_bound=BLEND * unit)
    within = np.isfinite(d[:, 0])
    close, d, at = candidates[within], d[within], at[within]
    weight = np.clip((BLEND * unit - d[:, 0]) / ((BLEND - CORE) * unit), 0.0, 1.0)
    w = np.where(np.isfinite(d), np.exp(-(((d - d[:, :1]) / unit) ** 2)), 0.0)
    at = np.minimum(at, points.shape[0] - 1)

    def spread(values):
        return weight * (values[at] * w).sum(axis=1) / w.sum(axis=1)

    change = np.zeros_like(phi)
    change[close] = spread(z * h * slopes)
    # the fit moves the surface's shape, not its volume, which the relaxation's pins keep:
    # the change of volume (to first order, the change of phi over its slope, integrated
    # over the surface; phi trilinear in each voxel) is undone by a uniform move
    mass = curvatures[1]
    shift = ((change[corner_ids] * corner_weights).sum(axis=1) / slopes * mass).sum() / mass.sum()
    change[close] -= shift * spread(slopes)
    result.phi = phi + change
    result.params["fitted_surface_vertices"] = int(keep.sum())
    return True


def _smooth_components(curvatures):
    """Whether each vertex lies on a connected surface that turns no sharper than
    :data:`CORNER` anywhere, from its :func:`_curvatures` (lengths in h).
    """
    K, mass, H0, gauss = curvatures
    n = mass.size
    kmax = np.abs(H0) + np.sqrt(np.maximum(H0**2 - gauss, 0.0))
    adjacency = (K != 0).astype(np.float64)
    near = adjacency + sp.identity(n)
    ring = ((near @ near) != 0).astype(np.float64)  # two rings: one is noisy on a small ball
    smooth = (ring @ (kmax * mass)) / (ring @ mass)
    count, label = connected_components(adjacency, directed=False)
    sharp = np.zeros(count, dtype=bool)
    np.logical_or.at(sharp, label, smooth > CORNER)
    return ~sharp[label]


def _curvatures(points, faces, normals):
    """The cotangent stiffness, the lumped mass, the mean curvature (positive where the
    surface bends away from its ``normals``, as a sphere from its outward ones) and the
    Gaussian curvature (angle defect) at the vertices of the triangle mesh.
    """
    from ..domains.simplicial import SimplicialComplex

    mesh = SimplicialComplex(points, faces)
    K, mass = mesh.K.tocsr(), np.asarray(mesh.mass, dtype=np.float64).ravel()
    H0 = 0.5 * ((K @ points) / mass[:, None] * normals).sum(axis=1)  # K x / M = -Delta x = 2 H n
    angle = np.zeros(points.shape[0])
    for k in range(3):
        a = points[faces[:, (k + 1) % 3]] - points[faces[:, k]]
        b = points[faces[:, (k + 2) % 3]] - points[faces[:, k]]
        cos = (a * b).sum(axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        np.add.at(angle, faces[:, k], np.arccos(np.clip(cos, -1.0, 1.0)))
    return K, mass, H0, (2.0 * np.pi - angle) / mass


class _Preconditioned:
    """Solves the Newton systems of one fit: the first by a Cholesky factor, the next by
    conjugate gradients preconditioned by the last factor (the systems differ only in the
    margins' weights), factorising anew when they take more than :data:`CG_STEPS` steps.
    """

    def __init__(self):
        self.factor = None

    def __call__(self, A, b):
        if self.factor is not None:
            M = spla.LinearOperator(A.shape, matvec=self.factor, dtype=np.float64)
            x, info = spla.cg(A, b, rtol=CG_RTOL, maxiter=CG_STEPS, M=M)
            if info == 0:
                return x
        self.factor = factorize_spd(A)
        return self.factor(b)


def _fit(points, normals, curvatures, sites, near, side, keep):
    """Each vertex's move along its normal minimising the module's loss (lengths in h;
    ``curvatures`` the surface's :func:`_curvatures`), the vertices not kept held; None
    when the Newton steps fail.
    """
    n = points.shape[0]
    K, mass, H0, gauss = curvatures
    A2 = np.maximum(4.0 * H0**2 - 2.0 * gauss, 0.0)
    # H(z) = H0 + B z: moving along n by z changes H by -(Delta z + |A|^2 z) / 2
    B = (0.5 * (sp.diags(1.0 / mass) @ K) - 0.5 * sp.diags(A2)).tocsr()
    free = np.flatnonzero(keep)
    B = B[:, free]
    prior, prior0 = (BETA * (B.T @ K @ B)).tocsr(), BETA * (B.T @ (K @ H0))
    signed = ((sites - points[near]) * normals[near]).sum(axis=1)
    column = np.full(n, -1)
    column[free] = np.arange(free.size)
    F = sp.csr_matrix((np.ones(near.size), (np.arange(near.size), column[near])), shape=(near.size, free.size))
    z, finite = margin_newton(
        prior, prior0, F, signed, -side, TAUS, np.zeros(free.size), ITERATIONS, TOLERANCE, _Preconditioned()
    )
    if not finite:
        return None
    out = np.zeros(n)
    out[free] = z
    return out
