"""Step 4: the smoothed field is integrated by least squares into phi.

``phi = argmin ||Delta phi - div X'||_M^2 + mu ||grad phi - X'||_A^2 + lam ||S phi - 1/2||^2``,
i.e. ``(K M^{-1} K + mu K + lam S^T S) phi = K M^{-1} d + mu d + lam S^T 1/2`` with
``d = G^T A X'``. ``mu = 0`` is the paper's energy; a small first-order term keeps phi
from bending where the squared Laplacian leaves it nearly free (far from zeta on thin
parts of a surface). ``form="plain"`` replaces ``M^{-1}`` by the identity: the paper's
unweighted ``K^T K``. ``form="gradient"`` fits the gradient itself,
``phi = argmin ||grad phi - X'||_A^2 + lam ||S phi - 1/2||^2``, i.e.
``(K + lam S^T S) phi = d + lam S^T 1/2`` (``mu`` plays no part): a screened Laplacian,
well conditioned where the squared one is not. Each point of zeta then pulls phi
towards 1/2 with a kink where the squared form bends smoothly: on a mesh, whose zeta is
a sparse set of vertices, that halves the fidelity on curved boundaries
(``tests/test_relax.py``); on the neighbour graph of data, where most samples end a cut
edge, the kinks average out, and it is the classifier's form
(:data:`ndboundary.learn.classifier.INTEGRATION_FORM`).

Lengths are measured in units of ``h`` (``K`` scales as ``h^{k-2}``, ``M`` as ``h^k``), so
``lam`` is dimensionless: a scaled, rotated or translated copy of the input relaxes to
the same level set, transformed. ``lam`` is also measured against the stiffness of the
field term at zeta (the median over zeta's vertices of the diagonal of ``K M^{-1} K``):
where a discretisation makes it weaker than the domain's reference
(:meth:`~ndboundary.Domain.lam_reference`, a regular Kuhn grid for meshes), ``lam`` is
scaled down by the same ratio, so that the boundary term does not pin the level set to
the jagged boundary's vertices. ``phi - 1/2`` then grows like the signed distance to the
relaxed boundary in units of ``h`` (with a slope below one near zeta, where the boundary
term flattens it).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..domains.image import GridBand, ImageGrid
from ..solvers import SolveInfo, factorize_spd, solve_gradient_integration, solve_integration
from ..solvers.integration import IntegrationFactor, integration_preconditioner

__all__ = [
    "IntegrationSystem",
    "boundary_weight_scale",
    "integrate",
    "integration_system",
    "integration_terms",
    "prepare",
    "with_rhs",
    "within_slabs",
]


@dataclass
class IntegrationSystem:
    """The integration problem in units of ``h``: ``(Kh Mh^{-1} Kh + mu Kh + lam S^T S) phi = rhs``,
    or ``(Kh + lam S^T S) phi = rhs`` for ``form="gradient"``.

    ``lam`` is the weight used (the given one times ``lam_scale``); ``mass`` is the mass in
    units of ``h`` (ones for ``form="plain"``); ``rhs`` is None until the field is known
    (:func:`integration_terms`); ``sweeps`` those of the domain's V-cycle
    (:attr:`~ndboundary.Domain.multigrid_sweeps`).

    Examples
    --------
    One built by the steps before it: see :func:`integration_system`. Its fields are the
    terms of the system, here of one segment held at both ends:

    >>> import numpy as np, scipy.sparse as sp
    >>> K = sp.csr_matrix([[1.0, -1.0], [-1.0, 1.0]])
    >>> S = sp.identity(2, format="csr")
    >>> system = IntegrationSystem(K, np.ones(2), S, 2.0, 1.0, 0.0, np.array([1.0, 1.0]))
    >>> phi, info = integrate(system, rtol=1e-10, solver="direct")
    >>> phi.round(6).tolist()
    [0.5, 0.5]
    """

    K: sp.csr_matrix
    mass: np.ndarray
    S: sp.csr_matrix
    lam: float
    lam_scale: float
    mu: float
    rhs: np.ndarray | None
    form: str = "mass"
    sweeps: int = 2


def boundary_weight_scale(work, h, sources):
    """The factor (at most 1) applied to ``lam`` on the padded domain ``work`` whose zeta
    has the vertices ``sources``: the field term's stiffness at zeta relative to the
    domain's reference (see the module docstring).

    It reads the stiffness and mass at zeta's vertices and their neighbours only, so the
    two rings of elements around zeta give the value of the whole domain.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, voronoi_polygons
    >>> from ndboundary.pipeline.integration import boundary_weight_scale
    >>> grid = kuhn_grid(20, 2)
    >>> round(boundary_weight_scale(grid, grid.mean_edge_length(), [200, 201]), 2)
    0.99
    >>> cells = voronoi_polygons(20, random_state=0)
    >>> bool(boundary_weight_scale(cells, cells.mean_edge_length(), [100, 101, 102]) < 1.0)
    True
    """
    k = work.element_dim
    return _lam_scale(work, work.K * h ** (2 - k), work.mass / h**k, np.asarray(sources))


def grid_scale_hint(domain, h):
    """An estimate of :func:`boundary_weight_scale` on an image grid (or its band), without padding or
    assembling it: the scale at the centre vertex of a 3 x 3 (x 3) grid of the same spacing
    and axes (every vertex inside a grid has that stiffness row; padding changes a few of
    zeta's rows, and their median little: on voxel balls of spacing 1:1:1 and 0.6:0.6:1.5
    the padded scale was 4 % and 6 % below it). None for other domains.

    Examples
    --------
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.pipeline.integration import grid_scale_hint
    >>> round(grid_scale_hint(ImageGrid((50, 50, 50)), 1.0), 3), grid_scale_hint(ImageGrid((4, 4, 40)), 1.0) <= 1.0
    (0.426, True)
    """
    if not isinstance(domain, (ImageGrid, GridBand)):
        return None
    dim = len(domain.shape)
    small = ImageGrid((3,) * dim, spacing=domain.spacing, direction=domain.direction)
    centre = int(np.ravel_multi_index((1,) * dim, (4,) * dim))
    return boundary_weight_scale(small, h, np.array([centre]))


def _lam_scale(work, Kh, mh, sources):
    """:func:`boundary_weight_scale` from the scaled stiffness ``Kh`` and mass ``mh``."""
    reference = work.lam_reference()
    if reference is None or sources.size == 0:
        return 1.0
    rows = Kh[sources]
    stiffness = np.asarray(rows.multiply(rows) @ (1.0 / mh)).ravel()
    return float(min(1.0, np.median(stiffness) / reference))


def integration_system(work, Xs, h, padded, sources, *, lam, mu, form):
    """Assemble step 4 for the smoothed field ``Xs`` on the padded domain ``work``.

    Examples
    --------
    Steps 0 to 4 by hand, as :func:`~ndboundary.relax` runs them:

    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.padding import pad
    >>> from ndboundary.pipeline.heat import diffuse
    >>> from ndboundary.pipeline.field import initial_field
    >>> from ndboundary.pipeline.smoothing import smooth
    >>> from ndboundary.pipeline.integration import integration_system, integrate
    >>> mesh = kuhn_grid(10, 2)
    >>> h = mesh.mean_edge_length()
    >>> region1 = label_by(mesh, circle) == 1
    >>> zeta = element_boundary(mesh, region1)
    >>> padded = pad(mesh, region1, zeta, "elements")
    >>> u, _ = diffuse(padded.work, zeta.sources, h**2, 1e-10)
    >>> X = smooth(padded.work, initial_field(mesh, padded, region1, zeta.sources, u, 1e-10), 60)
    >>> system = integration_system(padded.work, X, h, padded, zeta.sources, lam=2.0, mu=0.03, form="mass")
    >>> system.K.shape, system.rhs.shape
    ((121, 121), (121,))
    """
    return with_rhs(integration_terms(work, h, padded, sources, lam=lam, mu=mu, form=form), work, Xs, h, padded)


def integration_terms(work, h, padded, sources, *, lam, mu, form):
    """The terms of step 4 that the field does not enter: its :class:`IntegrationSystem`
    with ``rhs`` None, to be completed by :func:`with_rhs`. The relaxation builds them, and
    the solver's preconditioner (:func:`prepare`), beside the heat and field steps.
    """
    k = work.element_dim
    K = work.K.tocsr()
    # K's index arrays shared: a copy of the pattern is half a gigabyte on a large voxel band
    Kh = K if h == 1.0 else sp.csr_matrix((K.data * h ** (2 - k), K.indices, K.indptr), shape=K.shape)
    mh = work.mass / h**k
    sweeps = work.multigrid_sweeps
    if form == "gradient":
        return IntegrationSystem(Kh, mh, padded.S, lam, 1.0, 0.0, None, form, sweeps)
    mh_used = np.ones_like(mh) if form == "plain" else mh
    lam_scale = _lam_scale(work, Kh, mh, sources)
    return IntegrationSystem(Kh, mh_used, padded.S, lam * lam_scale, lam_scale, mu, None, form, sweeps)


def with_rhs(system, work, Xs, h, padded):
    """``system`` (:func:`integration_terms`) with the right-hand side of the smoothed
    field ``Xs``.
    """
    d = work.div(Xs) * h ** (1 - work.element_dim)
    field = d if system.form == "gradient" else system.K @ (d / system.mass) + system.mu * d
    return dataclasses.replace(system, rhs=field + system.lam * (padded.S.T @ padded.targets))


def prepare(system, *, solver, cache=None, concurrent=False):
    """The preconditioner or the factor :func:`integrate` will use for ``system``, built
    before its right-hand side is known
    (:func:`~ndboundary.solvers.integration.integration_preconditioner`, ``concurrent``
    when built beside the steps that compute the field); None when the solve builds its
    own, and for the first-order form.
    """
    if system.form == "gradient":
        return None
    return integration_preconditioner(
        system.K,
        system.mass,
        system.S,
        system.lam,
        mu=system.mu,
        method=solver,
        sweeps=system.sweeps,
        cache=cache,
        concurrent=concurrent,
    )


def integrate(system, *, rtol, solver, cache=None, preconditioner=None, x0=None):
    """Solve the integration system: ``(phi, SolveInfo)`` on the padded vertices.

    Examples
    --------
    Steps 0 to 4 by hand; phi's level set 1/2 is the relaxed boundary:

    >>> from ndboundary import marching_simplices
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.padding import pad
    >>> from ndboundary.pipeline.heat import diffuse
    >>> from ndboundary.pipeline.field import initial_field
    >>> from ndboundary.pipeline.smoothing import smooth
    >>> from ndboundary.pipeline.integration import integration_system, integrate
    >>> mesh = kuhn_grid(10, 2)
    >>> h = mesh.mean_edge_length()
    >>> region1 = label_by(mesh, circle) == 1
    >>> zeta = element_boundary(mesh, region1)
    >>> padded = pad(mesh, region1, zeta, "elements")
    >>> u, _ = diffuse(padded.work, zeta.sources, h**2, 1e-10)
    >>> X = smooth(padded.work, initial_field(mesh, padded, region1, zeta.sources, u, 1e-10), 60)
    >>> system = integration_system(padded.work, X, h, padded, zeta.sources, lam=2.0, mu=0.03, form="mass")
    >>> phi, info = integrate(system, rtol=1e-10, solver="auto")
    >>> curve = marching_simplices(mesh.points, mesh.simplices, phi[: mesh.n_vertices])
    >>> phi.shape, curve.is_closed(), curve.n_components()
    ((121,), True, 1)
    """
    if system.form == "gradient":
        K, S, lam, rhs = system.K, system.S, system.lam, system.rhs
        return solve_gradient_integration(K, S, lam, rhs, rtol=rtol, method=solver, cache=cache)
    return solve_integration(
        system.K, system.mass, system.S, system.lam, system.rhs, mu=system.mu, rtol=rtol, method=solver,
        preconditioner="auto" if preconditioner is None else preconditioner, sweeps=system.sweeps, cache=cache,
        x0=x0,
    )  # fmt: skip


#: How far (units of ``h``, read as ``phi - 1/2``) the level set may pass the centre of a
#: pixel next to a facet pin before :func:`within_slabs` lifts the pin: a boundary passing
#: within a hair of a pixel centre may come out on its other side, and a second solve for
#: that would not be worth its time (on a voxel ball of 160^3, 63 facets were lifted
#: without a margin and 7 with 0.05, costing 7 and 5 iterations; none with 0.1).
SLAB_MARGIN = 0.1

#: The second solve of :func:`within_slabs` corrects ``phi`` on the vertices within this
#: many rings of the lifted pins only, by a direct solve there (``phi`` held beyond), when
#: they are at most :data:`SLAB_LOCAL_SHARE` of the system: a few pins lifted on a large
#: band then cost what their neighbourhood costs, not conjugate gradients over the band.
SLAB_RINGS = 8
SLAB_LOCAL_SHARE = 0.05


def within_slabs(system, S, targets, slabs, phi, *, rtol, solver, cache=None, preconditioner=None):
    """``(phi, info, lifted)``: ``phi`` solved again where the level set passed the centre
    of a pixel next to a facet pin (:func:`~ndboundary.pipeline.boundary.facet_pins`) by
    :data:`SLAB_MARGIN` or more, those pins lifted to an even pin's weight; ``info`` None
    and ``lifted`` 0 when it kept every such centre on the side its label gives it.

    ``S``, ``targets`` and ``slabs`` are the rows of ``system`` as
    :class:`~ndboundary.pipeline.padding.Padded` holds them (``slabs`` None: no facet
    pins). The second solve starts from ``phi``.
    """
    if slabs is None or system.form == "gradient":
        return phi, None, 0
    inside, outside, lift = slabs
    root = 2.0 * targets
    known = (inside.min(axis=1) >= 0) & (outside.min(axis=1) >= 0)
    lifted = np.zeros(root.size, dtype=bool)
    lifted[known] = (phi[inside[known]].mean(axis=1) < 0.5 - SLAB_MARGIN) | (
        phi[outside[known]].mean(axis=1) > 0.5 + SLAB_MARGIN
    )
    lifted &= lift > root
    if not lifted.any():
        return phi, None, 0
    scale = np.ones(root.size)
    scale[lifted] = lift[lifted] / root[lifted]
    S2 = (sp.diags(scale) @ S).tocsr()
    rhs = system.rhs + system.lam * (S2.T @ (scale * targets) - S.T @ targets)
    system = dataclasses.replace(system, S=S2, rhs=rhs)
    near = _rings(system.K, np.unique(S2[np.flatnonzero(lifted)].indices), SLAB_RINGS)
    if near.size <= SLAB_LOCAL_SHARE * phi.size:
        tick = time.perf_counter()
        phi = _corrected_near(system, phi, near)
        return phi, SolveInfo("cholesky-near", 0, np.nan, solve_time=time.perf_counter() - tick), int(lifted.sum())
    if isinstance(preconditioner, IntegrationFactor):  # the factor of the system before the pins were lifted
        preconditioner = None
    phi, info = integrate(system, rtol=rtol, solver=solver, cache=cache, preconditioner=preconditioner, x0=phi)
    return phi, info, int(lifted.sum())


def _rings(K, seeds, rings):
    """The vertices within ``rings`` steps of ``seeds`` along the pattern of ``K``,
    increasing: grown from the last ring's rows alone, so that the cost follows them.
    """
    mask = np.zeros(K.shape[0], dtype=bool)
    mask[seeds] = True
    ring = np.asarray(seeds)
    for _ in range(rings):
        reached = K[ring].indices
        ring = np.unique(reached[~mask[reached]])
        if ring.size == 0:
            break
        mask[ring] = True
    return np.flatnonzero(mask)


def _corrected_near(system, phi, near):
    """``phi`` with the solution of ``system`` on the vertices ``near`` (``phi`` held on the
    others): the residual's restriction there, solved by a sparse Cholesky factor of the
    system's block.
    """
    K, mass, S, lam, mu = system.K, system.mass, system.S, system.lam, system.mu
    rows, Sn = K[near], S[:, near]
    around = np.unique(rows.indices)  # K phi is read on the rows' columns only
    Kx = np.zeros(phi.size)
    Kx[around] = K[around] @ phi
    residual = system.rhs[near] - (rows @ (Kx / mass) + mu * Kx[near] + lam * (Sn.T @ (S @ phi)))
    block = rows @ sp.diags(1.0 / mass) @ rows.T + mu * rows[:, near] + lam * (Sn.T @ Sn)
    out = phi.copy()
    out[near] += factorize_spd(((block + block.T) * 0.5).tocsc())(residual)
    return out
