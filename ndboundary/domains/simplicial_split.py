"""The operators of a padded simplicial complex, derived from its parent's.

Padding splits a few simplices at their barycentre (paper section 4); rebuilding every
operator of the split complex would cost as much as the parent's. Only the split
simplices change, so :class:`SplitOperators` recomputes the sums over the edges and
vertices they hold and keeps the parent's everywhere else, in the order a fresh build
adds them: the results are those of a fresh build.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .._arrays import counting_sort, expand_ranges, fill_unused_mass
from .simplex_geometry import stiffness_terms

__all__ = ["SplitOperators"]


class SplitOperators:
    """The operators of a complex made by :meth:`SimplicialComplex.split_elements`,
    derived from those of its parent, when the parent's stiffness is built.

    Only the split simplices change: the sums over the edges and vertices they hold
    are recomputed from every simplex holding them, in the order a fresh build adds
    them; the parent's sums are kept everywhere else. The results are those of a
    fresh build of the split complex.

    Parameters
    ----------
    parent : SimplicialComplex
    split : ndarray of int of shape (m,)
        The split simplices, increasing.
    keep : ndarray of bool of shape (n_elements,)
        The simplices of the parent that are not split.

    Notes
    -----
    The split complex holds the kept simplices in order, then its children in ``k + 1``
    blocks of ``m``: child ``i * m + j`` replaces vertex ``i`` (in the order of
    ``parent.simplices``) of simplex ``split[j]`` by its centre, vertex ``V + j``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import SimplicialComplex
    >>> from ndboundary.datasets import kuhn_grid
    >>> mesh = kuhn_grid(4, 2)
    >>> _ = mesh.K  # the parent's operators are built: the split patches them
    >>> work, parent = mesh.split_elements(np.arange(mesh.n_elements) < 2)
    >>> ops = work.split_from
    >>> ops.split.tolist(), ops.n_keep, work.n_elements
    ([0, 1], 30, 36)
    >>> fresh = SimplicialComplex(work.points, work.simplices)
    >>> bool(np.allclose(work.K.toarray(), fresh.K.toarray())), bool(np.allclose(work.mass, fresh.mass))
    (True, True)
    """

    def __init__(self, parent, split, keep):
        self.parent = parent
        self.split = split
        self.keep = keep
        self.n_keep = int(np.count_nonzero(keep))
        # sorted position of every vertex of the split simplices
        self.rank = np.argsort(np.argsort(parent.simplices[split], axis=1), axis=1)

    @cached_property
    def _split_vertices(self):
        """The vertices of the split simplices, as a mask over the parent's vertices."""
        mask = np.zeros(self.parent.n_vertices, dtype=bool)
        mask[self.parent.simplices[self.split].ravel()] = True
        return mask

    @cached_property
    def _star(self):
        """The kept simplices sharing a vertex with a split simplex, increasing."""
        P = self.parent
        near = self._split_vertices
        inc = P.__dict__.get("vertex_simplices", P.__dict__.get("incidence"))
        if inc is not None:
            rows = np.flatnonzero(near)
            held = np.zeros(P.n_elements, dtype=bool)
            held[inc.indices[expand_ranges(inc.indptr[rows], inc.indptr[rows + 1] - inc.indptr[rows])]] = True
        else:
            held = near[P.sorted_simplices].any(axis=1)
        return np.flatnonzero(held & self.keep)

    @cached_property
    def edge_map(self):
        """``(edges, old, new)``: the edges of the split complex (as ``edges``), the new id
        of every edge of the parent (-1 for an edge no simplex keeps) and, shape (m, k+1),
        the id of the edge from vertex ``srt[j, r]`` to the centre of ``split[j]``
        (``srt`` the sorted simplices).
        """
        P = self.parent
        V = P.n_vertices
        edges_p, pair_edge_p = P.edge_index
        srt = P.sorted_simplices[self.split]
        if srt.shape[1] == 2:
            # a split segment drops its edge unless a kept segment holds it too
            survive = np.bincount(pair_edge_p[self.keep], minlength=edges_p.shape[0]) > 0
            kept_edges = edges_p[survive]
        else:
            survive = None  # every edge of a split simplex is an edge of its children
            kept_edges = edges_p
        # the centre joins the vertices of its simplex, after every parent edge of each row
        by_row, new_before = counting_sort(srt.ravel(), V)
        row = srt.ravel()[by_row]
        new_pos = np.arange(row.size) + np.searchsorted(kept_edges[:, 0], row, side="right")
        old_pos = np.arange(kept_edges.shape[0]) + new_before[kept_edges[:, 0]]
        edges = np.empty((kept_edges.shape[0] + row.size, 2), dtype=edges_p.dtype)
        edges[old_pos] = kept_edges
        edges[new_pos, 0] = row
        edges[new_pos, 1] = V + by_row // srt.shape[1]
        if survive is None:
            old = old_pos
        else:
            old = np.full(edges_p.shape[0], -1, dtype=old_pos.dtype)
            old[survive] = old_pos
        new = np.empty(row.size, dtype=new_pos.dtype)
        new[by_row] = new_pos
        return edges, old, new.reshape(srt.shape)

    @cached_property
    def children_pair_edge(self):
        """The edge of every vertex pair of the children, (n_children, k (k + 1) / 2), in
        the order of ``edge_index``.
        """
        P = self.parent
        _, old, new = self.edge_map
        m, k1 = new.shape
        k = k1 - 1
        iu, ju = np.triu_indices(k1, 1)
        pair_of = np.zeros((k1, k1), dtype=np.intp)
        pair_of[iu, ju] = np.arange(iu.size)
        # position in the parent of child position r, for a child without parent position a
        pos = np.arange(k)[None, :] + (np.arange(k)[None, :] >= np.arange(k1)[:, None])
        to_centre = ju == k
        a = self.rank.T.ravel()
        j = np.tile(np.arange(m), k1)[:, None]
        first = pos[a][:, iu]
        second = pos[a][:, np.minimum(ju, k - 1)]
        pair_edge_p = P.edge_index[1].reshape(P.n_elements, -1)[self.split]
        inner = old[pair_edge_p[j, pair_of[first, second]]]
        return np.where(to_centre[None, :], new[j, first], inner)

    def edge_index(self):
        """``edge_index`` of the split complex."""
        P = self.parent
        edges, old, _ = self.edge_map
        pair_edge_p = P.edge_index[1].reshape(P.n_elements, -1)
        kept = old[pair_edge_p[self.keep]]
        return edges, np.concatenate([kept.ravel(), self.children_pair_edge.ravel()])

    def _recomputed(self, sums, targets, star_ids, star_terms, child_ids, child_terms):
        """Set ``sums[targets]`` to the sums of the terms of the star simplices whose ids
        are in ``targets`` (increasing), then of every term of the children.
        """
        star_ids = star_ids.ravel()
        sel = np.zeros(sums.size, dtype=bool)
        sel[targets] = True
        sel = sel[star_ids]
        ids = np.concatenate([star_ids[sel], child_ids.ravel()])
        terms = np.concatenate([star_terms.ravel()[sel], child_terms.ravel()])
        sums[targets] = np.bincount(np.searchsorted(targets, ids), weights=terms, minlength=targets.size)

    def stiffness_sums(self, child):
        """``stiffness_sums`` of the split complex ``child``."""
        P = self.parent
        off_p, diag_p, used_p = P.stiffness_sums
        edges, old, new = self.edge_map
        m = self.split.size
        n = self.n_keep
        star = self._star
        star_off, star_diag = stiffness_terms(P.barycentric_gradients[star], P.volumes[star])
        child_off, child_diag = stiffness_terms(child.barycentric_gradients[n:], child.volumes[n:])
        off = np.empty(edges.shape[0])
        if old.size == off_p.size and (old >= 0).all():
            off[old] = off_p
        else:
            off[old[old >= 0]] = off_p[old >= 0]
        pair_edge_p = P.edge_index[1].reshape(P.n_elements, -1)
        held = old[pair_edge_p[self.split]]
        targets = np.union1d(held[held >= 0], new.ravel())
        self._recomputed(off, targets, old[pair_edge_p[star]], star_off, self.children_pair_edge, child_off)
        diag = np.concatenate([diag_p, np.zeros(m)])
        targets = np.concatenate([np.flatnonzero(self._split_vertices), P.n_vertices + np.arange(m)])
        self._recomputed(diag, targets, P.sorted_simplices[star], star_diag, child.sorted_simplices[n:], child_diag)
        return off, diag, np.concatenate([used_p, np.ones(m, dtype=bool)])

    def mass(self, child):
        """The lumped mass of the split complex ``child`` from its parent's, or None when
        the parent's is not built.
        """
        P = self.parent
        if "mass" not in P.__dict__:
            return None
        k1 = P.simplices.shape[1]
        m = self.split.size
        n = self.n_keep
        star = self._star
        mass = np.concatenate([P.mass, np.zeros(m)])
        unused = ~P.vertex_used
        targets = np.concatenate([np.flatnonzero(self._split_vertices), P.n_vertices + np.arange(m)])
        self._recomputed(
            mass,
            targets,
            P.simplices[star],
            np.repeat(P.volumes[star] / k1, k1),
            child.simplices[n:],
            np.repeat(child.volumes[n:] / k1, k1),
        )
        fill_unused_mass(mass[: P.n_vertices], child.volumes / k1, unused)
        return mass
