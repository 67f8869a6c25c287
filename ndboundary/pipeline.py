"""The relaxation, written once for every domain (Livesu 2018, section 3).

1. **Heat**: ``(M + t K) u = b``, heat ``b`` placed on the jagged boundary zeta,
   ``t = t_factor * h^2`` with ``h`` the mean edge length.
2. **Field**: per element ``X = grad u / |grad u|`` in region 0 and ``-grad u / |grad u|``
   in region 1, so that ``X`` flows from region 0 across zeta into region 1. Where ``u``
   is below the iterative solver's accuracy (far from zeta), the direction comes from
   the graph distance to zeta instead. For vertex labels, elements whose vertices
   disagree take the gradient of the region-1 indicator.
3. **Smoothing**: ``smoothing`` passes of uniform averaging of each element's vector
   with its neighbours', renormalised after each pass (Jacobi order, as one sparse
   product). On surfaces the averages are not projected back onto each element's plane:
   the integration only sees the field through the divergence, and the projection
   measured worse on the shared triangle surfaces (3holes 0.078 h mean distance against
   0.049 h, torus 0.064 h against 0.047 h). kNN graphs transport their neighbours'
   vectors into each point's tangent space instead (see ``PointCloud``).
4. **Integration**: ``phi = argmin ||Delta phi - div X'||_M^2 + mu ||grad phi - X'||_A^2
   + lam ||S phi - 1/2||^2``, i.e. ``(K M^{-1} K + mu K + lam S^T S) phi = K M^{-1} d + mu d
   + lam S^T 1/2`` with ``d = G^T A X'``. ``mu = 0`` is the paper's energy; the small
   default first-order term keeps phi from bending where the squared Laplacian leaves it
   nearly free (far from zeta on thin parts of a surface).

Lengths are measured in units of ``h`` before step 4 (``K`` scales as ``h^{k-2}``, ``M``
as ``h^k``), so ``lam`` is dimensionless: a scaled, rotated or translated copy of the
input relaxes to the same level set, transformed. ``lam`` is also measured against the
stiffness of the field term at zeta (the median over zeta's vertices of the diagonal of
``K M^{-1} K``): where a discretisation makes it weaker than at a vertex of the regular
Kuhn grid (irregular meshes, and polygon and polyhedral cells with many short edges: down
to 1/30 on a Voronoi polyhedral mesh), ``lam`` is scaled down by the same ratio, so that
the boundary term does not pin the level set to the jagged boundary's vertices. Jittered
simplicial grids keep ``lam`` as given (their ratio is above 1); kNN graphs are not
rescaled. ``phi - 1/2`` then grows like the signed distance to the relaxed boundary in
units of ``h`` (with a slope below one near zeta, where the boundary term flattens it).

Before step 1, elements all of whose vertices receive heat are split at their
barycentre (padding, section 4), so that no element has a flat ``u``; the added
vertices are dropped from the returned ``phi``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from math import comb

import numpy as np
import scipy.sparse as sp

from ._validation import check_labels, check_nonnegative_int, check_positive
from .domain import Domain
from .levelset import LevelSet, marching_simplices
from .solvers import solve_heat, solve_integration

__all__ = ["relax", "RelaxResult", "Boundary", "DEFAULT_LAM", "DEFAULT_SMOOTHING", "DEFAULT_MU", "PAPER"]

#: Default weight of the boundary term (dimensionless, see the module docstring).
DEFAULT_LAM = 2.0
#: Default number of field smoothing passes.
DEFAULT_SMOOTHING = 60
#: From this many field rows, smoothing runs as a compiled loop (numba) that sums and
#: renormalises each row in one go: 3x faster on large fields, one compilation (about
#: 1 s, then cached on disk) per installation.
FUSED_SMOOTHING_MIN_ROWS = 200_000
#: Default weight of the first-order fit ``||grad phi - X'||^2`` added to the paper's
#: Laplacian fit: it anchors phi to the field far from zeta, where the squared
#: Laplacian alone lets phi bend freely (thin parts of a surface far from the boundary).
DEFAULT_MU = 0.03
#: The paper's own setting (Fig. 8, Table 1): 3 passes, its unweighted form, no first-order term.
PAPER = {"lam": 0.5, "smoothing": 3, "form": "plain", "mu": 0.0}

# Where the heat is below this fraction of its maximum, its gradient is at the level of
# the iterative solver's error (absolute, not relative): the field there follows the
# graph distance to zeta instead, which points the same way and is exact in any range.
_HEAT_FLOOR = 1e-5


@dataclass
class Boundary:
    """The jagged boundary zeta between the two regions.

    Attributes
    ----------
    sources : ndarray of int
        Vertices that receive heat (zeta's vertices for element labels; the ends of
        cut edges for vertex labels).
    S : sparse matrix of shape (n_points, n_vertices)
        One row per point of zeta with its interpolation weights over the vertices.
    points : ndarray of shape (n_points, dim)
        The points of zeta (``S @ domain.points``).
    edges : ndarray of int of shape (n_cut_edges, 2) or None
        For vertex labels, the edges whose ends differ.
    facets : ndarray of int of shape (n_facets, k) or None
        For element labels, the facets between elements of different labels: the
        jagged boundary as a complex over the domain's vertices.
    """

    sources: np.ndarray
    S: sp.csr_matrix
    points: np.ndarray
    edges: np.ndarray | None = None
    facets: np.ndarray | None = None


@dataclass
class RelaxResult:
    """What :func:`relax` returns.

    Attributes
    ----------
    phi : ndarray of shape (n_vertices,)
        The relaxed function; ``phi > 1/2`` in region 1 (``classes[1]``).
    u : ndarray of shape (n_vertices,)
        The heat (step 1), on the original vertices.
    field : ndarray of shape (n_padded_elements, dim)
        The unit field of step 2 on the padded domain.
    smoothed_field : ndarray of shape (n_padded_elements, dim)
        The field after step 3.
    boundary : Boundary
        The jagged boundary zeta.
    classes : ndarray of shape (2,)
        The label values of region 0 and region 1.
    timings : dict
        Seconds per step: ``pad`` (finding zeta, padding, and assembling the stiffness and
        mass of the padded domain when they are not cached yet), ``heat``, ``field``,
        ``smoothing``, ``integration``, ``total``.
    solver : dict of SolveInfo
        Per linear solve, its method, iterations and relative residual.
    params : dict
        The parameters used; ``lam_scale`` is the factor applied to ``lam`` (see
        :func:`relax`).
    """

    phi: np.ndarray
    u: np.ndarray
    field: np.ndarray
    smoothed_field: np.ndarray
    boundary: Boundary
    classes: np.ndarray
    domain: Domain
    timings: dict = field(default_factory=dict)
    solver: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    def level_set(self, value=0.5) -> LevelSet:
        """The level set ``phi == value`` (default 1/2, the relaxed boundary) by marching simplices."""
        value = float(value)
        if not np.isfinite(value):
            raise ValueError(f"value must be finite, got {value!r}")
        points, simplices, values = self.domain._level_set_complex(self.phi)
        return marching_simplices(points, simplices, values, value)


class _Progress:
    def __init__(self, verbose):
        self.verbose = bool(verbose)
        self.t0 = time.perf_counter()
        self.times = {}

    def step(self, name, t_start):
        dt = time.perf_counter() - t_start
        self.times[name] = dt
        if self.verbose:
            print(f"[ndboundary] {name:<12s} {dt:8.3f} s", file=sys.stderr, flush=True)
        return time.perf_counter()


def _element_boundary(domain, region1):
    """zeta for element labels: the vertices shared by elements of both labels."""
    inc = domain.incidence
    n1 = inc @ region1.astype(np.float64)
    n0 = inc @ (~region1).astype(np.float64)
    sources = np.flatnonzero((n1 > 0) & (n0 > 0))
    S = sp.csr_matrix(
        (np.ones(sources.size), (np.arange(sources.size), sources)), shape=(sources.size, domain.n_vertices)
    )
    return Boundary(sources, S, domain.points[sources], facets=domain._interface_facets(region1))


def _vertex_boundary(domain, region1):
    """zeta for vertex labels: the midpoints of the edges whose ends differ."""
    e = domain.edges
    cut = e[region1[e[:, 0]] != region1[e[:, 1]]]
    sources = np.unique(cut)
    m = cut.shape[0]
    S = sp.csr_matrix(
        (np.full(2 * m, 0.5), (np.repeat(np.arange(m), 2), cut.ravel())), shape=(m, domain.n_vertices)
    )
    return Boundary(sources, S, 0.5 * (domain.points[cut[:, 0]] + domain.points[cut[:, 1]]), cut)


def _graph_distance(domain, sources):
    """Shortest-path distance along the domain's edges from the vertices ``sources``.

    Vertices that no path reaches get distance 0 (they get no field direction).
    """
    from scipy.sparse.csgraph import dijkstra

    e = domain.edges
    w = np.linalg.norm(domain.points[e[:, 0]] - domain.points[e[:, 1]], axis=1)
    dist = dijkstra(domain._edge_graph(w), directed=False, indices=sources, min_only=True)
    dist[~np.isfinite(dist)] = 0.0
    return dist


def _pin_components_without_boundary(domain, S, vert_region1):
    """Constraint rows and targets: ``S`` at 1/2, and phi held at 1/2 -/+ 1 on the connected
    parts of the domain that zeta does not reach.

    There the field term alone leaves phi free up to a constant; pinning it keeps the
    system definite and puts the part on its own side of 1/2.
    """
    targets = np.full(S.shape[0], 0.5)
    n_comp, comp = domain._vertex_components
    if n_comp == 1:
        return S, targets
    touched = np.zeros(n_comp, dtype=bool)
    touched[comp[S.nonzero()[1]]] = True
    free = np.flatnonzero(~touched[comp])
    if free.size == 0:
        return S, targets
    rows = sp.csr_matrix((np.ones(free.size), (np.arange(free.size), free)), shape=(free.size, domain.n_vertices))
    return sp.vstack([S, rows]).tocsr(), np.concatenate([targets, np.where(vert_region1[free], 1.5, -0.5)])


def _grid_stiffness(k):
    """``diag(K M^{-1} K)`` at an interior vertex of the regular Kuhn grid of dimension ``k``,
    lengths in units of its mean edge length.

    On that grid, in units of the cell size, ``K`` is the ``2k + 1``-point Laplacian stencil
    and ``M = 1`` at interior vertices, so the diagonal is ``(2k)^2 + 2k``; the grid's edges
    join a vertex to its ``2^k - 1`` neighbours ``x + sum_{i in I} e_i``, of length
    ``sqrt(|I|)``, and the diagonal scales as ``length^{k-4}``.
    """
    sizes = np.arange(1, k + 1)
    mean_edge = float(np.sum([comb(k, j) * np.sqrt(j) for j in sizes])) / (2**k - 1)
    return (4 * k * k + 2 * k) * mean_edge ** (4 - k)


def _lam_scale(domain, Kh, mh, sources):
    """The factor (at most 1) applied to ``lam``: the field term's stiffness at zeta
    relative to the regular grid's (see the module docstring)."""
    if not domain._calibrate_lam or sources.size == 0:
        return 1.0
    rows = Kh[sources]
    stiffness = np.asarray(rows.multiply(rows) @ (1.0 / mh)).ravel()
    return float(min(1.0, np.median(stiffness) / _grid_stiffness(domain.element_dim)))


def _smooth_field(W, X, passes):
    """``passes`` sweeps of averaging by ``W`` and renormalising, in Jacobi order.

    ``W`` acts on the rows of the (n_elements, dim) field, or on the flattened field
    (kNN graphs transport vectors between tangent frames). Large fields of meshes go
    through one compiled loop per sweep (:data:`FUSED_SMOOTHING_MIN_ROWS`).
    """
    W = sp.csr_matrix(W)
    if W.shape[0] != X.shape[0]:
        Xs = X
        for _ in range(passes):
            Xs = _normalize_rows((W @ Xs.reshape(-1)).reshape(Xs.shape))
        return Xs
    if X.shape[0] >= FUSED_SMOOTHING_MIN_ROWS:
        from ._kernels import smooth_rows

        return smooth_rows(W, X, passes)
    Xs = X
    for _ in range(passes):
        Xs = _normalize_rows(W @ Xs)
    return Xs


def _normalize_rows(X):
    """Rows scaled to unit length; zero rows stay zero. Modifies and returns ``X``."""
    scale = np.sqrt(np.einsum("ij,ij->i", X, X))
    zero = ~(scale > 0)
    if zero.any():
        scale[zero] = np.inf
    np.divide(1.0, scale, out=scale)
    X *= scale[:, None]
    return X


def relax(
    domain,
    labels,
    *,
    on,
    lam=DEFAULT_LAM,
    smoothing=DEFAULT_SMOOTHING,
    mu=DEFAULT_MU,
    t=None,
    form="mass",
    pad=True,
    rtol=1e-10,
    solver="auto",
    verbose=False,
):
    """Relax the jagged boundary between two labelled regions into the level set ``phi = 1/2``.

    Parameters
    ----------
    domain : Domain
        A :class:`~ndboundary.SimplicialComplex` (or any other domain).
    labels : array-like of shape (n_elements,) or (n_vertices,)
        Two distinct values of any sortable type. Region 0 is ``np.unique(labels)[0]``,
        region 1 is ``np.unique(labels)[1]`` (for booleans: False, True; for 0/1: 0, 1).
    on : {"elements", "vertices"}
        Whether ``labels`` gives one label per element (a segmentation) or one per
        vertex (labelled data). Required: it is never guessed from the length.
    lam : float, default=2.0
        Weight of the boundary term ``||S phi - 1/2||^2`` against the field term;
        dimensionless, and scaled down on discretisations whose field term is weaker at
        zeta than on a regular simplicial grid (``params["lam_scale"]`` of the result;
        see the module docstring). Larger stays closer to the jagged boundary.
    smoothing : int, default=60
        Number of field smoothing passes. The paper uses 3-5, which leaves visible
        ripples; more passes relax further while ``lam`` keeps the boundary in place.
    t : float, optional
        Diffusion time in units of ``h^2`` (``h`` = mean edge length); default 1.
    form : {"mass", "plain"}, default="mass"
        ``"mass"`` integrates with the consistent ``K M^{-1} K``; ``"plain"`` with the
        paper's unweighted ``K^T K`` (both in units of ``h``).
    pad : bool, default=True
        Split the elements all of whose vertices receive heat (paper section 4).
    rtol : float, default=1e-10
        Relative residual the linear solves must reach. The heat is trusted down to
        ``max(1e-5, 100 rtol)`` of its maximum; below, the field follows the graph
        distance to zeta.
    solver : {"auto", "pcg", "direct"}, default="auto"
        How to solve the integration system (see :func:`ndboundary.solvers.solve_integration`).
    verbose : bool, default=False
        Print each step's time to stderr as it ends.

    Returns
    -------
    RelaxResult
    """
    if not isinstance(domain, Domain):
        raise TypeError(f"domain must be an ndboundary domain (e.g. SimplicialComplex), got {type(domain).__name__}")
    if on not in ("elements", "vertices"):
        raise ValueError(f"on must be 'elements' or 'vertices', got {on!r}")
    if form not in ("mass", "plain"):
        raise ValueError(f"form must be 'mass' or 'plain', got {form!r}")
    if solver not in ("auto", "pcg", "direct"):
        raise ValueError(f"solver must be 'auto', 'pcg' or 'direct', got {solver!r}")
    lam = check_positive(lam, "lam")
    mu = check_positive(mu, "mu", allow_zero=True)
    smoothing = check_nonnegative_int(smoothing, "smoothing")
    t_factor = 1.0 if t is None else check_positive(t, "t")
    rtol = check_positive(rtol, "rtol")
    n_expected = domain.n_elements if on == "elements" else domain.n_vertices
    classes, region1 = check_labels(labels, n_expected, what=on[:-1])

    prog = _Progress(verbose)
    t0 = tick = time.perf_counter()
    V = domain.n_vertices
    h = domain.mean_edge_length()

    # zeta, and padding of the elements that would get a flat heat
    if on == "elements":
        boundary = _element_boundary(domain, region1)
        straddle = np.zeros(domain.n_elements, dtype=bool)
    else:
        boundary = _vertex_boundary(domain, region1)
        per_elem = domain.incidence.T @ region1.astype(np.float64)
        size = np.asarray(domain.incidence.sum(axis=0)).ravel()
        straddle = (per_elem > 0) & (per_elem < size)
    if boundary.sources.size == 0:
        raise ValueError("the two regions never meet: labels form no boundary on this domain")
    hot = np.zeros(V, dtype=bool)
    hot[boundary.sources] = True
    flat = (domain.incidence.T @ (~hot).astype(np.float64)) == 0
    flat &= ~straddle
    if pad and flat.any():
        work, parent = domain._split_elements(flat)
    else:
        work, parent = domain, np.arange(domain.n_elements)
    if on == "elements":
        elem_region1 = region1[parent]
    else:
        elem_region1 = (domain.incidence.T @ region1.astype(np.float64))[parent] > 0
        straddle = straddle[parent]
    vert_region1 = region1 if on == "vertices" else (domain.incidence @ region1.astype(np.float64)) > 0
    S, targets = _pin_components_without_boundary(domain, boundary.S, vert_region1)
    S = sp.hstack([S, sp.csr_matrix((S.shape[0], work.n_vertices - V))]).tocsr()
    K, mass = work.K, work.mass  # assembled (and timed) with the padding
    tick = prog.step("pad", tick)

    # 1. heat
    b = np.zeros(work.n_vertices)
    b[boundary.sources] = mass[boundary.sources]
    u, heat_info = solve_heat(mass, K, t_factor * h * h, b, rtol=rtol)
    tick = prog.step("heat", tick)

    # 2. field: the heat gradient where the heat is resolved; further away, where u is
    # below the solver's accuracy, the gradient of the graph distance to zeta
    X = _normalize_rows(work.gradient(u))
    far = work._element_max(u) < max(_HEAT_FLOOR, 100.0 * rtol) * u.max()
    if far.any():
        # distances on the unpadded domain; a padding vertex takes its element's mean
        dist = _graph_distance(domain, boundary.sources)
        split = np.flatnonzero(flat) if work is not domain else np.zeros(0, dtype=np.int64)
        if work.n_vertices - V == split.size:
            inc = domain.incidence[:, split].T.tocsr()
            dist = np.concatenate([dist, (inc @ dist) / np.diff(inc.indptr)])
        else:
            dist = _graph_distance(work, boundary.sources)
        X[far] = -_normalize_rows(work.gradient(dist)[far])
    X[elem_region1] *= -1.0
    if straddle.any():
        ind = np.zeros(work.n_vertices)
        ind[:V] = region1
        X[straddle] = _normalize_rows(work.gradient(ind)[straddle])
    tick = prog.step("field", tick)

    # 3. smoothing, Jacobi order: average, renormalise
    Xs = _smooth_field(work._smoothing_operator(), X, smoothing) if smoothing else X
    tick = prog.step("smoothing", tick)

    # 4. integration, lengths in units of h
    k = work.element_dim
    Kh = K * h ** (2 - k)
    mh = mass / h**k
    d = work.div(Xs) * h ** (1 - k)
    if form == "plain":
        mh_used = np.ones_like(mh)
    else:
        mh_used = mh
    lam_scale = _lam_scale(work, Kh, mh, boundary.sources)
    lam_used = lam * lam_scale
    rhs = Kh @ (d / mh_used) + mu * d + lam_used * (S.T @ targets)
    # a padded copy's operators are not needed by the solve: free them before it
    # (at 1M triangle-mesh vertices, 0.5 GB of the peak memory)
    work = K = None
    psi, int_info = solve_integration(Kh, mh_used, S, lam_used, rhs, mu=mu, rtol=rtol, method=solver)
    tick = prog.step("integration", tick)

    timings = dict(prog.times)
    timings["total"] = time.perf_counter() - t0
    if verbose:
        print(f"[ndboundary] {'total':<12s} {timings['total']:8.3f} s", file=sys.stderr, flush=True)
    return RelaxResult(
        phi=psi[:V].copy(),
        u=u[:V].copy(),
        field=X,
        smoothed_field=Xs,
        boundary=boundary,
        classes=classes,
        domain=domain,
        timings=timings,
        solver={"heat": heat_info, "integration": int_info},
        params={"lam": lam, "lam_scale": lam_scale, "smoothing": smoothing, "mu": mu, "t": t_factor, "form": form, "pad": bool(pad), "on": on, "h": h},
    )
