"""Step 1: heat diffuses from the jagged boundary, ``(M + t K) u = b``.

``b`` places heat on zeta's vertices (the heat sources) in proportion to their mass,
and ``t = t_factor h^2`` with ``h`` the mean edge length (paper section 3, after the
heat method of Crane et al.). The system is mass dominated and well conditioned:
conjugate gradients solve it in a few dozen iterations at any size.
"""

from __future__ import annotations

import numpy as np

from ..solvers import solve_heat

__all__ = ["diffuse"]


def diffuse(work, sources, t, rtol):
    """The heat ``u`` on the padded domain ``work`` after time ``t`` (absolute), and the solve's report.

    Parameters
    ----------
    work : Domain
    sources : ndarray of int
        The heated vertices.
    t : float
        Diffusion time, ``t_factor * h**2``.
    rtol : float
        Relative residual the solve must reach.

    Returns
    -------
    u : ndarray of shape (work.n_vertices,)
    info : SolveInfo

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.heat import diffuse
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = element_boundary(mesh, label_by(mesh, circle) == 1)
    >>> u, info = diffuse(mesh, zeta.sources, mesh.mean_edge_length() ** 2, 1e-10)
    >>> u.shape, bool(u.argmax() in zeta.sources), bool(info.residual < 1e-8)
    ((121,), True, True)
    """
    mass = work.mass
    b = np.zeros(work.n_vertices)
    b[sources] = mass[sources]
    return solve_heat(mass, work.K, t, b, rtol=rtol)
