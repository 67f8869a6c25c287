"""The smoothed-aggregation AMG V-cycle (package pyamg) that preconditions the
integration solve on meshes and graphs with dense rows: :func:`amg_preconditioner`,
and the Jacobi step on light vertices around it: :func:`light_vertex_jacobi`. On meshes
the hierarchy is built by the compiled passes of :mod:`.amg_hierarchy`.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .._compiled import pattern_sums
from .amg_hierarchy import energy_hierarchy
from .amg_sweeps import ForwardSweeps
from .common import load_optional, one_blas_thread

__all__ = ["AMG_DENSE_ROWS", "AMG_STRENGTH", "LIGHT_VERTEX_SHARE", "amg_preconditioner", "light_vertex_jacobi"]

#: Rows of the AMG operator ``K + D`` with more entries than this on average (neighbour
#: graphs) get a Jacobi-smoothed prolongator, sparser ones (meshes) an energy-minimising
#: one (see :func:`amg_preconditioner`). Tetrahedral meshes have about 14 entries per
#: row, the neighbour graphs of the classifier about 90: the threshold sits between.
AMG_DENSE_ROWS = 40.0
#: On meshes the aggregation reads the couplings of ``K + D`` no weaker than this share
#: of the largest in their rows (:func:`~.amg_hierarchy.strong_pattern`). On voxels of
#: 0.6 x 0.6 x 4 mm (a ball in 64 x 64 x 16 of them) the integration took 43 iterations
#: against 161 over every coupling; 0.05 to 0.25 gave the same 43. On isotropic hexahedra
#: and tetrahedra it took one to three fewer (a 64^3 voxel ball, a 70^3 Kuhn grid).
AMG_STRENGTH = 0.1
#: A vertex whose lumped mass is below this share of the mean of its neighbours' is
#: "light" (:func:`light_vertex_jacobi`). On the band systems of tetrahedral grids the
#: iterations were the same from 0.1 to 1 (54 at 400 K unknowns), and 10 % more with
#: every vertex counted light.
LIGHT_VERTEX_SHARE = 0.5


def amg_preconditioner(A, sweeps=2):
    """One smoothed-aggregation V-cycle approximating ``A^{-1}`` (package pyamg).

    The settings were chosen by the wall time (setup plus conjugate gradients) of
    :func:`~ndboundary.solvers.solve_integration` on two cores, on tetrahedral Kuhn grids
    (rtol 1e-10) and on the neighbour graph of random points (rtol 1e-6), against
    pyamg's defaults and other variants; ``benchmarks/solvers.py`` measures them
    (figures in the README).

    * Gauss-Seidel on every level: ``sweeps`` forward sweeps before the coarse
      correction and as many backward ones after (the cycle stays symmetric, at half
      the work of symmetric sweeps, for two more iterations on a 257 K-unknown
      tetrahedral band, and 13 % less time in a 100 K-sample fit of
      ``benchmarks/scale.py``). Two each way by default: on tetrahedral and hexahedral
      meshes and on slices of voxels one needed a quarter to a third more iterations and
      as much time or more; on cubic voxels (:attr:`~ndboundary.Domain.multigrid_sweeps`)
      it needed two more iterations of 17 and saved a sixth of the solve;
      Chebyshev smoothing needed more than twice the iterations (close to the default
      limit of ``maxiter`` on large meshes); a W-cycle took longer for the same
      iterations.
    * Every level in CSR format. pyamg builds the coarse operators in BSR format with
      1x1 blocks, where Gauss-Seidel is far slower than on the finer CSR level several
      times their size: in CSR (converted on graphs, built so on meshes) a V-cycle on
      meshes is much cheaper.
    * No improvement of the constant candidate vector (the null space of ``K``) by
      block Gauss-Seidel: without it, fewer iterations and a shorter setup.
    * The tentative prolongator smoothed by energy minimisation, two iterations of it,
      when the rows of ``A`` have at most :data:`AMG_DENSE_ROWS` entries on average
      (meshes: fewer iterations and less time than one Jacobi step; pyamg's four cost a
      third more setup for the same iterations), by one Jacobi step on denser rows (neighbour
      graphs: there the energy minimisation's setup costs more than the iterations it
      saves). Plain aggregation (no smoothing) needed many more iterations, which its
      cheaper setup did not make up for. The hierarchy of the energy minimisation is
      built by compiled passes (:func:`~ndboundary.solvers.amg_hierarchy.energy_hierarchy`)
      that reproduce pyamg's levels, the same aggregates and the same operators up to
      rounding, in a quarter of its setup time (0.45 s against 1.9 s on the 277 K-unknown
      band of a 1 M-vertex tetrahedral grid): pyamg builds them in BSR format with new
      sparse matrices at every step.
    * ``max_coarse = 500``. On meshes the aggregates follow the strong couplings of
      each row, those no weaker than :data:`AMG_STRENGTH` times its largest
      (:func:`~.amg_hierarchy.strong_pattern`): on stretched cells (scans of thick
      slices) they stay within the slices, and the iterations fall several times. On
      graphs, pyamg's symmetric strength with ``theta = 0``. Thresholds of that
      measure (``|a_ij| / sqrt(a_ii a_jj)``) were tried on tetrahedral meshes: 0.05-0.1
      built deeper and denser hierarchies whose setup cost more than the iterations
      they saved, and 0.25 left two levels and several times the iterations.
      The coarsest level is solved by a dense pseudo-inverse (pyamg's
      ``"pinv"``), which is why it is kept small: ``max_coarse = 5000`` made the solve
      an order of magnitude slower.
    * The cycle runs in single precision, its coarsest solve in double: its sweeps and
      products read memory faster than they compute, and float32 entries halve the
      values they read. The conjugate gradients around it stay in double precision, and
      reach the same residuals in the same iterations (21 on the band of a 192^3 voxel
      ball, whose integration took a fifth less time).

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite, with the constants close to its null space.
    sweeps : int, default=2
        Gauss-Seidel sweeps on each level before the coarse correction, and after it.

    Returns
    -------
    apply : callable
        ``apply(r)`` returns the V-cycle applied to ``r``: a symmetric positive definite
        operator (the smoothers are symmetric), to the single precision of its cycle.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> n = 50  # a path graph's Laplacian plus a small diagonal
    >>> A = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) + 0.01 * sp.identity(n)
    >>> apply = amg_preconditioner(A)
    >>> u, v = np.random.default_rng(0).standard_normal((2, n))
    >>> bool(np.isclose(u @ apply(v), v @ apply(u))), bool(u @ apply(u) > 0)
    (True, True)
    >>> bool(np.allclose(A @ apply(v), v))  # one level: the coarse solve is exact
    True
    """
    pyamg = load_optional("pyamg")
    A = sp.csr_matrix(A)
    if A.nnz / max(A.shape[0], 1) > AMG_DENSE_ROWS:
        ml = pyamg.smoothed_aggregation_solver(
            A, symmetry="symmetric", strength="symmetric", smooth="jacobi", improve_candidates=None, max_coarse=500
        )
        for level in ml.levels:
            for name in ("A", "P", "R"):
                M = getattr(level, name, None)
                if M is not None and sp.issparse(M) and M.format != "csr":
                    setattr(level, name, M.tocsr())
        levels, solver = ml.levels, ml.coarse_solver

        def coarse(b):
            return np.asarray(solver(levels[-1].A, b), dtype=np.float64).reshape(b.shape)

    else:
        levels = energy_hierarchy(A, maxiter=2, max_coarse=500, theta=AMG_STRENGTH)
        with one_blas_thread():  # at most 500 rows: more threads gain nothing, and took 1 s with the other core busy
            inverse = sla.pinv(levels[-1].A.toarray())  # pyamg's "pinv" coarse solver

        def coarse(b):
            return inverse @ b

    # forward sweeps before the coarse correction and backward ones after keep the cycle
    # symmetric at half the fine-level work of symmetric sweeps
    return _v_cycle(levels, coarse, sweeps, pyamg.amg_core.gauss_seidel)


def _v_cycle(levels, coarse, sweeps, gauss_seidel):
    """One V-cycle over ``levels`` (finest first, each with ``A`` and, but the coarsest,
    ``P`` and ``R``, all CSR), in single precision (copies of their entries, the index
    arrays shared) but for the coarsest solve, which alone is the exact inverse in
    double: ``sweeps`` forward Gauss-Seidel sweeps before the coarse correction and as many
    backward ones after it (their adjoints: the cycle is symmetric), the coarsest level
    solved by ``coarse(b)``.

    The forward sweeps return the residual they leave (:mod:`.amg_sweeps`), the first
    reading only the lower triangle from ``x = 0``: the pre-smoothing and its residual
    read a level's matrix ``sweeps - 1/2`` times instead of ``sweeps + 1``. A level whose
    diagonal is not positive or whose indices are 64-bit sweeps by pyamg's
    ``gauss_seidel`` and forms its residual by a product. pyamg's preconditioner runs the
    same cycle but also computes the residual's norm before and after it, two more
    products with the finest operator each time.
    """
    last = len(levels) - 1
    if last == 0:  # the coarse solve alone, exact
        return lambda r: coarse(np.asarray(r, dtype=np.float64))
    single = [
        (_single(level.A), _single(getattr(level, "P", None)), _single(getattr(level, "R", None))) for level in levels
    ]
    fused = [_forward_sweeps(A) for A, _, _ in single]

    def pre_smooth(lvl, b):
        if fused[lvl] is not None:
            x, r = fused[lvl].from_zero(b)
            for _ in range(sweeps - 1):
                r = fused[lvl].sweep(b, x)
            return x, r
        A = single[lvl][0]
        x = np.zeros_like(b)
        for _ in range(sweeps):
            gauss_seidel(A.indptr, A.indices, A.data, x, b, 0, A.shape[0], 1)
        return x, b - A @ x

    def cycle(lvl, b):
        if lvl == last:
            return np.asarray(coarse(b.astype(np.float64)), dtype=np.float32)
        A, P, R = single[lvl]
        x, r = pre_smooth(lvl, b)
        x += P @ cycle(lvl + 1, R @ r)
        for _ in range(sweeps):
            gauss_seidel(A.indptr, A.indices, A.data, x, b, A.shape[0] - 1, -1, -1)
        return x

    return lambda r: cycle(0, np.ascontiguousarray(r, dtype=np.float32)).astype(np.float64)


def _forward_sweeps(A):
    """The :class:`~.amg_sweeps.ForwardSweeps` of ``A``, None where they do not apply."""
    try:
        return ForwardSweeps(A)
    except (TypeError, ValueError):
        return None


def _single(M):
    """The CSR matrix ``M`` with float32 entries and sorted indices, sharing its index
    arrays when they are sorted already (None stays None).
    """
    if M is None:
        return None
    if not M.has_sorted_indices:
        M = M.sorted_indices()
    out = sp.csr_matrix((M.data.astype(np.float32), M.indices, M.indptr), shape=M.shape)
    out.has_sorted_indices = True
    return out


def light_vertex_jacobi(A, mass, apply):
    """Wrap ``apply`` (approximately ``A^{-1}``) in a Jacobi step on the light vertices,
    before and after it.

    The integration's preconditioner ``V M V`` (``V`` approximating ``A^{-1}``, ``M`` the
    lumped mass) is accurate as far as ``M^{-1/2} (I - A V)`` is small: a residual that
    the V-cycle leaves on a vertex of mass ``m`` counts ``1 / sqrt(m)`` times. Vertices
    much lighter than their neighbours (held by one or two small elements: the ragged
    edge of a band, the vertices padding adds inside an element) thus slow conjugate
    gradients down. A Jacobi step on those vertices, whose mass is below
    :data:`LIGHT_VERTEX_SHARE` of the mean of their neighbours', zeroes their residual
    after the V-cycle; the same step before it keeps the operator symmetric positive
    definite (symmetric multiplicative Schwarz): ``x = B r``, ``x += V (r - A x)``,
    ``x += B (r - A x)``, ``B`` the inverse diagonal of ``A`` on the light vertices. It
    costs two products with their rows of ``A``, and took the integration on the band of
    a 1 M-vertex tetrahedral grid (540 K unknowns, 5 % of them light) from 463 iterations
    to 59, on a whole 250 K-vertex grid from 91 to 50 (``benchmarks/solvers.py``); on
    neighbour graphs it changed nothing.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite, with the pattern of the mesh's vertex adjacency.
    mass : ndarray of shape (n,)
        Lumped mass of each vertex, positive.
    apply : callable
        ``apply(r)``: a symmetric positive definite approximation of ``A^{-1} r``.

    Returns
    -------
    apply : callable
        ``apply`` itself when no vertex is light, else the wrapped operator.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> n = 6  # a path whose last vertex is light
    >>> A = sp.diags([-np.ones(n - 1), 2.1 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    >>> mass = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.05])
    >>> D = 1.0 / A.diagonal()
    >>> wrapped = light_vertex_jacobi(A, mass, lambda r: D * r)
    >>> u, v = np.random.default_rng(0).standard_normal((2, n))
    >>> bool(np.isclose(u @ wrapped(v), v @ wrapped(u))), bool(u @ wrapped(u) > 0)
    (True, True)
    >>> float(abs(v - A @ wrapped(v))[-1]) < 1e-12  # no residual left on the light vertex
    True
    >>> light_vertex_jacobi(A, np.ones(n), np.negative) is np.negative  # none light
    True
    """
    A = sp.csr_matrix(A)
    diag = A.diagonal()
    neighbours = np.diff(A.indptr) - (diag != 0)
    around = (pattern_sums(A, mass) - np.where(diag != 0, mass, 0.0)) / np.maximum(neighbours, 1)
    light = np.flatnonzero((mass < LIGHT_VERTEX_SHARE * around) & (neighbours > 0))
    if light.size == 0:
        return apply
    rows = A[light]
    inv = 1.0 / diag[light]

    def wrapped(r):
        x = np.zeros_like(r)
        x[light] = inv * r[light]
        x += apply(r - rows.T @ x[light])
        x[light] += inv * (r[light] - rows @ x)
        return x

    return wrapped
