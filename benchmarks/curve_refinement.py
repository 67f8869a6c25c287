"""A prototype estimator studied by ``images_limits.py`` and ``regions_refine.py``: a relaxed
curve in the plane moved to the smoothest curve that parts the labelled sites near it with
the largest margins. Not part of the library.

The curve is resampled at equal steps and each vertex moved along the curve's normal by
``delta``, one Newton solve of

    beta * sum(kappa'^2) step + sum(exp(-margin / tau)),

``kappa`` the curvature of the moved curve (linearised about the given one), ``kappa'``
its change from vertex to vertex, and ``margin`` each site's signed distance to the moved
curve, positive on its label's side. The first term is a prior of least curvature change
(circles and lines cost nothing); the second keeps the sites on their sides, the nearest
most. An open curve keeps its two ends (junctions, or points on the domain's border, which
are fitted elsewhere). Lengths are in the caller's units: pass coordinates in units of h
for ``beta`` and ``tau`` in h.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree


def polylines(points, segments):
    """The polylines a set of segments forms: ``(vertices, closed)`` for each chain between
    vertices of degree other than 2 (junctions, ends) and for each closed loop.
    """
    around = defaultdict(list)
    for a, b in np.asarray(segments).tolist():
        around[a].append(b)
        around[b].append(a)
    used = set()

    def walk(start):
        path, previous, v = [start], None, start
        while True:
            ahead = [w for w in around[v] if w != previous and (min(v, w), max(v, w)) not in used]
            if not ahead:
                return path
            w = ahead[0]
            used.add((min(v, w), max(v, w)))
            path.append(w)
            previous, v = v, w
            if len(around[v]) != 2:
                return path

    out = []
    for v in [v for v in around if len(around[v]) != 2]:
        while any((min(v, w), max(v, w)) not in used for w in around[v]):
            out.append((points[walk(v)], False))
    for v in list(around):
        if any((min(v, w), max(v, w)) not in used for w in around[v]):
            path = walk(v)
            out.append((points[path[:-1]], True) if path[0] == path[-1] else (points[path], False))
    return out


def resample(points, spacing, closed):
    """The polyline at equal arclength steps of about ``spacing``: ``(vertices, step)``; a
    closed one returns each vertex once, an open one keeps both ends.
    """
    chain = np.vstack([points, points[:1]]) if closed else points
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(chain, axis=0), axis=1))])
    m = max(8 if closed else 2, int(round(s[-1] / spacing)))
    t = np.linspace(0.0, s[-1], m + 1)
    out = np.stack([np.interp(t, s, chain[:, k]) for k in range(points.shape[1])], axis=1)
    return (out[:-1] if closed else out), s[-1] / m


def _stencil(rows, cols, weights, step, cyclic=False):
    """The ``rows`` x ``cols`` matrix whose row ``i`` holds ``weights[k] / step`` at column
    ``i + k`` (modulo ``cols`` when ``cyclic``)."""
    i = np.arange(rows)
    columns = np.concatenate([(i + k) % cols if cyclic else i + k for k in range(len(weights))])
    values = np.concatenate([np.full(rows, w / step) for w in weights])
    return sp.csr_matrix((values, (np.tile(i, len(weights)), columns)), shape=(rows, cols))


def _differences(n, step, closed):
    """``(D, D2)``: on a cycle, forward differences and the centred second differences at
    every vertex; on a chain, None and the centred second differences at the vertices that
    have both neighbours (row ``i`` for vertex ``i + 1``); over ``step``.
    """
    if closed:
        D = _stencil(n, n, (-1.0, 1.0), step, cyclic=True)
        return D, (-(D.T @ D)).tocsr()
    return None, _stencil(n - 2, n, (1.0, -2.0, 1.0), step**2)


def refine(points, step, sites, side, beta, tau, closed=True):
    """The polyline ``points`` (equal steps ``step``) moved along its normals: see the
    module docstring. ``side`` is +1 for the sites on one side, -1 for the other.
    """
    n = points.shape[0]
    tangent = (np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)) if closed else np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    nearest = cKDTree(points).query(sites)[1]
    signed = ((sites - points[nearest]) * normal[nearest]).sum(axis=1)
    if np.mean(np.sign(signed) == -side) < 0.5:  # the normals point away from the +1 side
        normal, signed = -normal, -signed
    along = np.clip(((sites - points[nearest]) * tangent[nearest]).sum(axis=1) / step, -0.999, 0.999)
    j0 = np.where(along >= 0, nearest, nearest - 1)
    w = np.where(along >= 0, along, 1.0 + along)
    if closed:
        j0 %= n
    else:  # sites beyond an open curve's ends have no foot on it
        on = (j0 >= 0) & (j0 < n - 1)
        j0, w, signed, side = j0[on], w[on], signed[on], side[on]
    m = j0.size
    ends = (np.tile(np.arange(m), 2), np.r_[j0, (j0 + 1) % n])
    foot = sp.csr_matrix((np.r_[1.0 - w, w], ends), shape=(m, n))  # each site's foot, between two vertices
    D, D2 = _differences(n, step, closed)
    inner = slice(None) if closed else slice(1, -1)
    kappa = (D2 @ points * -normal[inner]).sum(axis=1)  # positive where the curve turns to the +1 side
    rows = np.arange(kappa.size)
    dkappa = -D2 - sp.csr_matrix((kappa**2, (rows, rows if closed else rows + 1)), shape=(kappa.size, n))
    if not closed:  # kappa' between consecutive inner vertices
        D = _stencil(kappa.size - 1, kappa.size, (-1.0, 1.0), step)
    A = D @ dkappa
    H0, g0 = beta * step * (A.T @ A), beta * step * (A.T @ (D @ kappa))
    free = np.arange(n) if closed else np.arange(1, n - 1)
    delta = np.zeros(n)
    for _ in range(30):
        e = np.exp(np.clip(-side * (foot @ delta - signed) / tau, -50.0, 50.0))
        grad = H0 @ delta + g0 - foot.T @ (side * e / tau)
        hess = (H0 + foot.T @ sp.diags(e / tau**2) @ foot).tocsr()[free][:, free] + 1e-9 * sp.identity(free.size)
        move = spla.spsolve(hess.tocsc(), -grad[free])
        delta[free] += move
        if np.abs(move).max() < 1e-7:
            break
    return points + delta[:, None] * normal
