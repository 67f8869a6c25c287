"""What a relaxation returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..levelset import LevelSet, marching_simplices
from .boundary import Boundary

__all__ = ["RelaxResult"]


@dataclass
class RelaxResult:
    """What :func:`~ndboundary.relax` returns.

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
    domain : Domain
        The domain relaxed on.
    timings : dict
        Seconds per step: ``pad`` (finding zeta, padding, and assembling the stiffness and
        mass of the padded domain when they are not cached yet), ``heat``, ``field``,
        ``smoothing``, ``integration``, ``total``.
    solver : dict of SolveInfo
        Per linear solve, its method, iterations and relative residual.
    params : dict
        The parameters used; ``lam_scale`` is the factor applied to ``lam`` (see
        :mod:`ndboundary.pipeline.integration`).

    Examples
    --------
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> mesh = kuhn_grid(20, 2)
    >>> result = relax(mesh, label_by(mesh, circle), on="elements")
    >>> result.level_set().n_components()
    1
    """

    phi: np.ndarray
    u: np.ndarray
    field: np.ndarray
    smoothed_field: np.ndarray
    boundary: Boundary
    classes: np.ndarray
    domain: object
    timings: dict = field(default_factory=dict)
    solver: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    def level_set(self, value=0.5) -> LevelSet:
        """The level set ``phi == value`` (default 1/2, the relaxed boundary) by marching simplices."""
        value = float(value)
        if not np.isfinite(value):
            raise ValueError(f"value must be finite, got {value!r}")
        points, simplices, values = self.domain.level_set_complex(self.phi)
        return marching_simplices(points, simplices, values, value)
