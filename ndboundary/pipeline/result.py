"""What a relaxation returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..levelset import LevelSet, marching_simplices
from ..partition import partition
from .boundary import Boundary

__all__ = ["RegionsResult", "RelaxResult"]


class _RegionMethods:
    """The partition of the domain by the largest of the region functions, and what it gives."""

    def region_values(self):
        """One function per region, shape (n_vertices, n_regions); the largest wins."""
        raise NotImplementedError

    def partition(self):
        """The exact partition (:func:`ndboundary.partition.partition`) of the domain's
        simplicial refinement by the largest region function, built once.
        """
        cached = self.__dict__.get("_partition")
        if cached is None:
            points, simplices, values = self.domain.level_set_complex(self.region_values())
            cached = self.__dict__["_partition"] = partition(points, simplices, values)
        return cached

    def interfaces(self):
        """The interfaces between the relaxed regions (``pairs`` index ``classes``), with
        their junctions (:class:`~ndboundary.partition.Interfaces`).
        """
        return self.partition().interfaces()

    def region_boundary(self, r):
        """Region ``r``'s boundary, oriented outward, as a :class:`~ndboundary.LevelSet`."""
        return self.partition().region_boundary(r)

    def region_measures(self):
        """Area / volume of every relaxed region, shape (n_regions,): they sum to the domain's."""
        return self.partition().region_measures()


@dataclass
class RelaxResult(_RegionMethods):
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

    def region_values(self):
        """``(1 - phi, phi)``: region 0 where ``phi < 1/2``, region 1 where ``phi > 1/2``."""
        return np.stack([1.0 - self.phi, self.phi], axis=1)

    def level_set(self, value=0.5) -> LevelSet:
        """The level set ``phi == value`` (default 1/2, the relaxed boundary) by marching simplices."""
        value = float(value)
        if not np.isfinite(value):
            raise ValueError(f"value must be finite, got {value!r}")
        points, simplices, values = self.domain.level_set_complex(self.phi)
        return marching_simplices(points, simplices, values, value)


@dataclass
class RegionsResult(_RegionMethods):
    """What :func:`~ndboundary.relax` returns for three or more labels.

    Attributes
    ----------
    phi : ndarray of shape (n_vertices, n_regions)
        One relaxed function per region, columns in ``classes`` order: region ``r``'s
        function is above 1/2 in region ``r``. A point belongs to the region whose
        function is largest there.
    classes : ndarray of shape (n_regions,)
    domain : Domain
    regions : list of RelaxResult
        Region ``r`` relaxed against the rest.
    timings : dict
        Seconds per step, summed over the regions, and ``total``.
    params : dict

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> mesh = kuhn_grid(30, 2, jitter=0.2, random_state=0)
    >>> c = mesh.element_centroids()
    >>> labels = np.where(c[:, 0] < 0, 0, np.where(c[:, 1] < 0, 1, 2))  # a T of three regions
    >>> result = relax(mesh, labels, on="elements")
    >>> result.phi.shape, round(float(result.region_measures().sum()), 9)
    ((961, 3), 4.0)
    >>> len(result.interfaces().junctions())
    1
    """

    phi: np.ndarray
    classes: np.ndarray
    domain: object
    regions: list
    timings: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    def region_values(self):
        """The region functions ``phi``."""
        return self.phi
