"""Padding (paper section 4): split the elements whose heat would be flat.

An element all of whose vertices lie on zeta receives the same heat at every vertex:
its gradient, and so the field of step 2, is undefined. Such elements are split at their
barycentre by the domain (:meth:`~ndboundary.Domain.split_elements`) before step 1; the
added vertices are dropped from the returned phi.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..domains.image import GridBand, ImageGrid
from .boundary import Boundary, facet_pins, pinned_rows

__all__ = ["Padded", "pad"]


@dataclass
class Padded:
    """The domain the four steps run on, and what the labels say on it.

    Attributes
    ----------
    work : Domain
        The padded domain (the input domain itself when nothing was split).
    split : ndarray of int
        The input elements that were split, increasing.
    parent : ndarray of int of shape (work.n_elements,)
        The input element each padded element lies in.
    elem_region1 : ndarray of bool of shape (work.n_elements,)
        Elements of region 1 (for vertex labels: holding a region-1 vertex).
    straddle : ndarray of bool of shape (work.n_elements,)
        For vertex labels, the elements whose vertices disagree (they cross zeta).
    flat : ndarray of bool of shape (work.n_elements,)
        The elements all of whose vertices receive heat that were left whole (padding
        disabled): their field is their neighbours' (:func:`~ndboundary.pipeline.field.initial_field`).
    S : sparse matrix of shape (n_rows, work.n_vertices)
        The constraint rows of the integration: zeta's points, and one row per vertex of
        a domain component that zeta does not reach.
    targets : ndarray of shape (n_rows,)
        Their values: 1/2 on zeta, 1/2 -/+ 1 on the components without boundary (times
        the rows' weights, on image grids).
    slabs : tuple of three ndarrays, or None
        On image grids, what the facet pins' slabs are checked on
        (:func:`~ndboundary.pipeline.boundary.facet_pins`): each row's two pixels' corners
        (-1 for rows that are not facets) and the scale its row takes where the level set
        passes one of their centres.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.padding import pad
    >>> mesh = kuhn_grid(10, 2)
    >>> region1 = label_by(mesh, circle) == 1
    >>> padded = pad(mesh, region1, element_boundary(mesh, region1), "elements")
    >>> padded.work is mesh, padded.split.size, padded.S.shape  # nothing to split here
    (True, 0, (20, 121))
    """

    work: object
    split: np.ndarray
    parent: np.ndarray
    elem_region1: np.ndarray
    straddle: np.ndarray
    flat: np.ndarray
    S: sp.csr_matrix
    targets: np.ndarray
    slabs: tuple | None = None


def pad(domain, region1, boundary: Boundary, on, enabled=True, *, vertex_pins=False, all_reached=False):
    """Split the elements all of whose vertices receive heat, and carry the labels over.

    Parameters
    ----------
    domain : Domain
    region1 : ndarray of bool
        Region 1, per element or per vertex (``on``).
    boundary : Boundary
    on : {"elements", "vertices"}
    enabled : bool, default=True
        False leaves the domain as it is: the flat elements take their neighbours' field
        (:attr:`Padded.flat`).
    vertex_pins : bool, default=False
        Pin zeta's vertices alike on an image grid too, instead of its facets weighted
        by how they turn from the boundary (:func:`~ndboundary.pipeline.boundary.facet_pins`).
        A partition of three regions or more does: its largest function decides between
        regions, and on a face all of treads, such as a frame one pixel thick, the
        lighter pins let a neighbour's function overtake the frame's at the image's
        border (``tests/test_images.py``).
    all_reached : bool, default=False
        Zeta is known to reach every connected part of the domain, as it reaches every
        part of a band around it (:func:`~ndboundary.pipeline.boundary.pinned_rows`).

    Returns
    -------
    Padded

    Examples
    --------
    A single labelled triangle has all its vertices on zeta: it is split at its barycentre.

    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.padding import pad
    >>> mesh = kuhn_grid(10, 2)
    >>> region1 = np.arange(mesh.n_elements) == 0
    >>> padded = pad(mesh, region1, element_boundary(mesh, region1), "elements")
    >>> padded.split.tolist(), padded.work.n_vertices, padded.work.n_elements
    ([0], 122, 202)
    """
    if on == "elements":
        straddle = np.zeros(domain.n_elements, dtype=bool)
    else:
        straddle = domain.elements_at(region1) & domain.elements_at(~region1)
    hot = np.zeros(domain.n_vertices, dtype=bool)
    hot[boundary.sources] = True
    flat = ~domain.elements_at(~hot) & ~straddle
    if enabled and flat.any():
        work, parent = domain.split_elements(flat)
    else:
        work, parent = domain, np.arange(domain.n_elements)
    split = np.flatnonzero(flat) if work is not domain else np.zeros(0, dtype=np.int64)
    left = flat if work is domain else np.zeros(work.n_elements, dtype=bool)  # flat elements left whole
    if on == "elements":
        elem_region1 = region1[parent]
        vert_region1 = domain.vertices_of(region1)
    else:
        elem_region1 = domain.elements_at(region1)[parent]
        straddle = straddle[parent]
        vert_region1 = region1
    slabs = None
    if on == "elements" and not vertex_pins and isinstance(domain, (ImageGrid, GridBand)):
        S, targets, (inside, outside, lift) = facet_pins(domain, region1, boundary.sources)
        S, targets = pinned_rows(domain, S, vert_region1, targets, all_reached)
        more = S.shape[0] - lift.size  # the rows of parts that zeta does not reach
        slabs = tuple(np.concatenate([a, np.full((more,) + a.shape[1:], -1)]) for a in (inside, outside))
        slabs += (np.concatenate([lift, np.zeros(more)]),)
    else:
        S, targets = pinned_rows(domain, boundary.S, vert_region1, boundary.targets, all_reached)
    S = sp.hstack([S, sp.csr_matrix((S.shape[0], work.n_vertices - domain.n_vertices))]).tocsr()
    return Padded(work, split, parent, elem_region1, straddle, left, S, targets, slabs)
