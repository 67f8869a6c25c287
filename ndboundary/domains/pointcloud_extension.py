"""Vertex functions of a kNN point cloud evaluated at new points.

The neighbour-weighted first-order extension
``sum_j w_j [phi_j + grad phi_j . T_j^T (x - x_j)] / sum_j w_j`` over the ``k`` training
points nearest to ``x``, with tangent gradients and frames ``T_j`` and weights
``w_j = (1 - e_j^2 / e_{k+1}^2) (d_1 / d_j)^p``, ``e_j`` the distance to the ``j``-th
nearest, ``e_{k+1}`` to the next one and ``d_j`` the locally scaled distance below: a
neighbour's weight fades to 0 before it leaves the set, so the extension is continuous
in ``x``. On no more than ``k`` samples it uses all but the farthest, so that there is
always a next one to fade against (without it every weight would be 1, and the extension
at any point the mean of all the samples' extensions).

The ratios are of locally scaled distances: the ``k + 1`` nearest training points are
found by the Euclidean distance (which the taper uses, so that the extension stays
continuous), and ``d_j = e_j / s_j``, ``d_1`` the smallest of them, with ``s_j`` the
distance from training point ``j`` to its :data:`LOCAL_SCALE_RANK`-th nearest other
sample (the self-tuning scale of Zelnik-Manor and Perona, 2004): how many of its own
spreads away ``x`` lies. Where the classes have different densities, a point far from
the data would otherwise follow the dense class, whose samples are the nearest to
everything around them (they are hubs; Schnitzer et al., JMLR 2012, remove them by
such scales). A sample of a tight class, whose first-order model was fitted within a
small reach, counts less the more of its spreads ``x`` lies away: beyond a tight
cluster's reach, a point follows the spread class around it. (The symmetric scaling
``e_j / sqrt(s_x s_j)`` ranks the neighbours of ``x`` alike but weighs them by
``sqrt(s_j)`` only, which keeps more of the hubs' weight.) A point on a training
sample (``e_1 = 0``) still takes its value.

``[.]`` clamps each sample's first-order value to the range of ``phi`` over that
sample's stencil (itself and its graph neighbours, over which its gradient was fitted):
a linear fit says nothing beyond the values it was fitted on. Where ``phi`` has a spike
(a lone sample of a class, its neighbours on a plateau), the neighbours' gradients point
steeply at it and their linear extrapolations past it, or out of the data's hull, would
climb above every value of ``phi`` around them; from the spike itself, any slope would
rise above its value. Clamped, the extension at ``x`` lies within the range of ``phi``
over the stencils of the samples it draws on (no longer extrapolating past the data)
and stays continuous, since the bounds belong to the samples, not to ``x``. The price is
exactness on linear functions wherever ``x`` lies beyond the values a neighbour's
stencil holds, which inside the data, with stencils wider than the extension's
neighbourhood, is rare and small. The stencil is the sample's graph neighbours, or its
``n_neighbors`` nearest samples if those reach further.

The power ``p`` sets how sharply it follows the nearest samples (for ``p > 0`` a point on
a training sample takes that sample's value); ``power="auto"`` chooses it by the
leave-one-out accuracy of the extension at labelled training samples, which needs no
refit since ``phi`` stays as fitted (:class:`NeighborExtension` gives the rules).
"""

from __future__ import annotations

import threading

import numpy as np

from .._compiled import ambient_values, neighbour_means
from .._threads import in_blocks

__all__ = ["EXTENSION_POWERS", "LOCAL_SCALE_RANK", "NeighborExtension", "predicted_codes"]

#: The powers ``power="auto"`` chooses from; on equal leave-one-out accuracy the
#: earlier one is kept.
EXTENSION_POWERS = (0.0, 2.0, 4.0, 8.0, 16.0, 32.0)

#: The local scale of a point is its distance to its ``LOCAL_SCALE_RANK``-th nearest
#: sample (the 7 of Zelnik-Manor and Perona's self-tuning spectral clustering).
LOCAL_SCALE_RANK = 7
_CHUNK = 8192


def rows_of(X, rows, transform, held):
    """The rows ``rows`` (a slice or indices) of ``X``, mapped by ``transform`` where it is
    given (called as ``transform(A, out=B)``, ``B`` possibly ``A``), in an array that
    ``held`` (a thread's ``threading.local``) keeps for every block of rows the thread
    reads, and overwrites at the next: an array made for each block would be faulted in
    afresh, at a cost of the order of the gather itself.
    """
    if transform is None and isinstance(rows, slice):
        return X[rows]
    m = len(range(*rows.indices(X.shape[0]))) if isinstance(rows, slice) else rows.size
    buffer = getattr(held, "rows", None)
    if buffer is None or buffer.shape[0] < m:
        buffer = held.rows = np.empty((max(m, _CHUNK), X.shape[1]))
    out = buffer[:m]
    if isinstance(rows, slice):
        return transform(X[rows], out=out)
    np.take(X, rows, axis=0, out=out, mode="clip")  # "raise" would gather into a copy first
    return out if transform is None else transform(out, out=out)


def _weighted_mean(vals, taper, log_ratio, power):
    """Weighted mean over neighbours of ``vals`` (b, q, r): weights ``taper (d_1 / d_q)^power``."""
    w = taper * np.exp(-power * log_ratio)
    return np.einsum("bq,bqr->br", w, vals) / w.sum(axis=1)[:, None]


def predicted_codes(phi):
    """Class codes of extension values: ``phi > 1/2`` for one column, the largest otherwise."""
    return (phi[:, 0] > 0.5).astype(np.int64) if phi.shape[1] == 1 else np.argmax(phi, axis=1)


class NeighborExtension:
    """The first-order extension of vertex functions of a point cloud to new points.

    Parameters
    ----------
    cloud : PointCloud
    phi : ndarray of shape (n_samples, n_functions)
        The functions at the cloud's points.
    n_neighbors : int, default=25
        Nearest training samples averaged at a new point.
    power : float or "auto", default="auto"
        Power ``p`` of the weights (module docstring); ``"auto"`` picks the one of
        :data:`EXTENSION_POWERS` whose leave-one-out extension labels the most samples
        of ``labels`` right, among those that keep every class at one of its own
        samples at least (and, on no more than ``n_neighbors + 1`` samples, not 0).
    labels : ndarray of int of shape (n_samples,), optional
        Class codes (column indices; for one function, 0 and 1); needed by ``"auto"``.
    labelled : ndarray of bool of shape (n_samples,), optional
        The samples whose labels count; by default all.

    Attributes
    ----------
    power : float
        The power used.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> X = np.random.default_rng(0).normal(size=(300, 2))
    >>> cloud = PointCloud(X, n_neighbors=40)
    >>> ext = cloud.extension(X[:, :1], power=0.0)  # the function x
    >>> round(float(ext(np.array([[0.1, 0.2]]))[0, 0]), 3)  # first order inside the data
    0.1
    >>> bool(ext(np.array([[10.0, 0.0]]))[0, 0] <= X[:, 0].max())  # outside, within the values of phi
    True
    """

    def __init__(self, cloud, phi, *, n_neighbors=25, power="auto", labels=None, labelled=None):
        self.cloud = cloud
        self.n_neighbors = int(n_neighbors)
        phi = np.asarray(phi, dtype=np.float64).reshape(cloud.n_vertices, -1)
        u = cloud.unique_inverse
        n_u = cloud.unique_points.shape[0]
        cnt = np.bincount(u, minlength=n_u).astype(np.float64)
        self._phi_u = np.stack([np.bincount(u, weights=p, minlength=n_u) for p in phi.T], axis=1) / cnt[:, None]
        grads = []
        for p in phi.T:
            g = cloud.gradient(p)[: cloud.points.shape[0]]  # (N, m)
            gu = np.stack([np.bincount(u, weights=g[:, a], minlength=n_u) for a in range(g.shape[1])], axis=1)
            grads.append(gu / cnt[:, None])
        self._grad_u = np.stack(grads, axis=1)  # (n_u, r, m)
        # With no more functions than tangent dimensions, the gradients are kept in
        # ambient coordinates instead, g_j = T_j grad_j and c_j = phi_j - g_j . x_j, so a
        # value is c_j + g_j . x with no frame gathered per neighbour (fewer products,
        # and g holds no more numbers than the frames).
        self._ambient = None
        if self._grad_u.shape[1] <= cloud.intrinsic_dim:
            g = np.einsum("udm,urm->urd", cloud.frames, self._grad_u)  # (n_u, r, D)
            self._ambient = (self._phi_u - np.einsum("urd,ud->ur", g, cloud.unique_points), g)
        # the bounds of each sample's first-order extension: the range of phi over its
        # gradient stencil
        around = self._phi_u[cloud.neighbors]  # (n_u, q, r)
        self._lo = np.minimum(self._phi_u, around.min(axis=1))
        self._hi = np.maximum(self._phi_u, around.max(axis=1))
        self._scale = cloud.distances[:, min(LOCAL_SCALE_RANK, cloud.distances.shape[1]) - 1]
        self._loo = self._at_samples = None
        if power == "auto":
            if labels is None:
                raise ValueError("power='auto' chooses the power by leave-one-out accuracy: it needs labels")
            self.power, self._loo, self._at_samples = self._choose_power(np.asarray(labels), labelled)
        else:
            self.power = float(power)

    def __call__(self, X, transform=None):
        """The functions at the points ``X`` (n, n_features), or at ``transform(X)``: shape
        (n, n_functions).

        Blocks of points are evaluated on several threads (:func:`~ndboundary._threads.in_blocks`);
        beyond one block, in the cloud's :meth:`~ndboundary.PointCloud.query_order`, which
        makes the searches of the neighbours faster and changes no value. Each block's rows
        are gathered in that order, and transformed, on their own, into an array each thread
        keeps (:func:`rows_of`): no reordered or transformed copy of ``X`` is made, whose
        memory, made afresh at each call, the system may have to fault in again.
        """
        X = np.asarray(X, dtype=np.float64)
        out = np.empty((X.shape[0], self._phi_u.shape[1]))
        order = self.cloud.query_order(X, transform) if X.shape[0] > _CHUNK else None
        # a block's rows, searches and sums written into arrays each thread keeps for all
        # its blocks; where the index searches into given arrays and the gradients are
        # ambient, one compiled pass instead of a dozen arrays per block
        into = self._ambient is not None and self.cloud.searches_into
        held = threading.local()

        def block(c):
            rows = c if order is None else order[c]
            points = rows_of(X, rows, transform, held)
            if into:
                out[rows] = self._means_into(points, held)
                return
            for _, *terms in self._terms(points):  # one chunk
                out[rows] = _weighted_mean(*terms, self.power)

        for _ in in_blocks(X.shape[0], _CHUNK, block, first_alone=self.cloud.query_prepares):
            pass
        return out

    def _means_into(self, X, scratch):
        """The functions at the points ``X`` (at most ``_CHUNK`` rows), in an array of
        ``scratch`` (a thread's own): the neighbours searched into arrays it keeps, then
        weighed and summed by :func:`~ndboundary._compiled.neighbour_means`.
        """
        k, nxt = self._sizes(0)
        n, width = X.shape[0], k + nxt
        held = getattr(scratch, "arrays", None)
        if held is None or held[0].shape[0] < n:
            rows = max(n, _CHUNK)
            held = scratch.arrays = (
                np.empty((rows, X.shape[1]), dtype=np.float32),
                np.empty((rows, width), dtype=np.float32),
                np.empty((rows, width), dtype=np.int64),
                np.empty((rows, self._phi_u.shape[1])),
            )
        x32, sq, ind, means = (a[:n] for a in held)
        x32[...] = X
        self.cloud.kneighbors_into(x32, sq, ind)
        c, g = self._ambient
        neighbour_means(ind, sq, self._scale, c, g, X, self._lo, self._hi, float(self.power), k, nxt, means)
        return means

    def for_queries(self):
        """A copy that evaluates new points only (no :meth:`leave_one_out`), over a lean
        copy of the cloud (:meth:`~ndboundary.PointCloud.for_queries`).
        """
        lean = object.__new__(type(self))
        tangent = self._ambient is None
        cloud = self.cloud.for_queries(frames=tangent)
        lean.__dict__.update(self.__dict__, _loo=None, _at_samples=None, cloud=cloud)
        if not tangent:  # values come from the ambient gradients alone
            lean._grad_u = None
        return lean

    def leave_one_out(self, rows):
        """The extension at the training samples ``rows``, each one's own point left out:
        shape (len(rows), n_functions).
        """
        if self._loo is not None and np.array_equal(rows, self._loo[0]):
            return self._loo[1]
        rows = np.asarray(rows)
        out = np.empty((rows.size, self._phi_u.shape[1]))
        for c, *terms in self._terms(self.cloud.points[rows], rows=rows):
            out[c] = _weighted_mean(*terms, self.power)
        return out

    def at_samples(self, rows):
        """The extension at the training samples ``rows``, their own points kept:
        shape (len(rows), n_functions). The same as calling it at their points, and
        kept from the choice of the power when it was made on these rows.
        """
        if self._at_samples is not None and np.array_equal(rows, self._at_samples[0]):
            return self._at_samples[1]
        return self(self.cloud.points[np.asarray(rows)])

    def held_out(self, rows):
        """The extension at the training samples ``rows`` as if each had not been sampled:
        shape (len(rows), n_functions).

        :meth:`leave_one_out` leaves a sample's own point out of the average, but its
        neighbours' gradients were fitted over stencils that hold it, and their clamp
        ranges include its value: extrapolated from a neighbour back to the sample, the
        first-order term returns part of the sample's own ``phi``. Those estimates are
        optimistic (on data sparse for its dimension by up to 12 points of accuracy),
        alike for every power, so they still rank the powers, but not this extension
        against another estimator. Here each neighbour's gradient is the least-squares
        fit over its stencil without the sample (a rank-one downdate: with ``c`` the
        sample's column of the neighbour's coefficients ``(Z^T Z)^-1 Z^T``, ``h = z . c``
        its leverage and ``r`` its residual, the value at the sample moves by
        ``-r h / (1 - h)``) and its clamp range the range of ``phi`` over the rest of
        the stencil. What the relaxation drew from the sample's label stays in ``phi``;
        on the sets of ``benchmarks/classify.py`` these estimates come within about one
        point of the test accuracy.
        """
        rows = np.asarray(rows)
        dom = self.cloud
        k, nxt = self._sizes(1)
        out = np.empty((rows.size, self._phi_u.shape[1]))
        # each sample's stencil with its two smallest and two largest values, for the
        # clamp ranges without one of them
        stencil = np.concatenate([self._phi_u[:, None, :], self._phi_u[dom.neighbors]], axis=1)
        ordered = np.sort(stencil, axis=1)
        lo1, lo2, hi1, hi2 = ordered[:, 0], ordered[:, 1], ordered[:, -1], ordered[:, -2]
        dom.sample_neighbors(k + nxt)  # searched once, before the blocks read it

        def block(c):
            u = dom.unique_inverse[rows[c]]
            X = dom.points[rows[c]]
            ind, dist = self._others(rows[c], k + nxt)
            _, taper, log_ratio = self._from_neighbors(X, ind, dist, k, nxt)
            ind = ind[:, :k]
            off = dom.tangent_offsets(X, ind)  # (b, k, m)
            vals = self._phi_u[ind] + np.einsum("bqrm,bqm->bqr", self._grad_u[ind], off)
            # where the sample is in a neighbour's stencil: its column there
            hit = dom.neighbors[ind] == u[:, None, None]  # (b, k, K)
            has = hit.any(axis=2)
            col = np.where(has[..., None], dom._coef[ind, :, hit.argmax(axis=2)], 0.0)  # (b, k, m)
            h = np.minimum((col * off).sum(axis=2), 1.0 - 1e-6)
            own = self._phi_u[u][:, None, :]
            vals = vals - (own - vals) * (h / (1.0 - h))[..., None]
            alone_lo = has[..., None] & (own <= lo1[ind])
            alone_hi = has[..., None] & (own >= hi1[ind])
            lo = np.where(alone_lo, lo2[ind], lo1[ind])
            hi = np.where(alone_hi, hi2[ind], hi1[ind])
            out[c] = _weighted_mean(np.clip(vals, lo, hi), taper, log_ratio, self.power)

        for _ in in_blocks(rows.size, _CHUNK, block):  # blocks of samples on several threads
            pass
        return out

    def _choose_power(self, labels, labelled):
        """``(power, (rows, loo), (rows, kept))``: the power of :data:`EXTENSION_POWERS`
        whose leave-one-out extension labels the most labelled samples right, that
        extension there, and the extension there with their own points kept.

        Only powers that keep every class are candidates: at its own samples (their own
        points kept), the extension must give each class at least one of them. Leaving
        a sample out cannot see a class of one sample (or of a few far apart), and every
        neighbour the class's samples sway counts against them, so the smoothest power
        would always erase such a class; the relaxation kept it, and the extension
        should not remove it altogether. On no more samples than ``n_neighbors + 1`` the
        neighbourhood is the whole set and power 0 its global average, so it is not a
        candidate either. Among equals the first (smoothest) is kept.
        """
        rows = np.arange(labels.shape[0]) if labelled is None else np.flatnonzero(labelled)
        lab = labels[rows]
        powers = np.asarray(EXTENSION_POWERS)
        right = np.zeros(powers.size, dtype=np.int64)
        loo = np.empty((powers.size, rows.size, self._phi_u.shape[1]))
        own = np.empty((powers.size, rows.size), dtype=np.int64)
        at = np.empty((powers.size, rows.size, self._phi_u.shape[1]))
        for c, left_out, kept in self._training_terms(rows):
            for i, p in enumerate(powers):
                phi = loo[i, c] = _weighted_mean(*left_out, p)
                right[i] += int((predicted_codes(phi) == lab[c]).sum())
                at[i, c] = _weighted_mean(*kept, p)
                own[i, c] = predicted_codes(at[i, c])
        classes = np.unique(lab)
        keeps = np.array([np.isin(classes, lab[own[i] == lab]).all() for i in range(powers.size)])
        if self.cloud.n_unique <= self.n_neighbors + 1:
            keeps &= powers > 0.0
        best = int(np.argmax(np.where(keeps, right, -1))) if keeps.any() else int(np.argmax(right))
        return float(powers[best]), (rows, loo[best]), (rows, at[best])

    def _sizes(self, own):
        """``(k, nxt)``: the neighbours averaged, and whether a next one exists to fade against."""
        n_u = self.cloud.n_unique
        # keep a (k+1)-th neighbour for the weights to fade against whenever there is one
        # to spare: without it every weight would be 1 and, on fewer samples than k, the
        # extension the mean of all first-order extensions, an affine function
        k = max(1, min(self.n_neighbors, n_u - own - 1))
        return k, 1 if k + own < n_u else 0

    def _training_terms(self, rows):
        """Per chunk of the training samples ``rows``: ``(slice, left_out, kept)``, the
        :meth:`_terms` of each sample with its own point left out and kept, from one
        neighbour search (the graph's when it holds enough neighbours).
        """
        dom = self.cloud
        k1, nxt1 = self._sizes(1)
        k0, nxt0 = self._sizes(0)
        need = max(k1 + nxt1, k0 + nxt0 - 1)
        X = dom.points[rows]
        dom.sample_neighbors(need)  # searched once, before the blocks read it

        def block(c):
            u = dom.unique_inverse[rows[c]]
            ind, dist = self._others(rows[c], need)
            left_out = self._from_neighbors(X[c], ind[:, : k1 + nxt1], dist[:, : k1 + nxt1], k1, nxt1)
            with_self = np.concatenate([u[:, None], ind], axis=1)[:, : k0 + nxt0]
            zero = np.concatenate([np.zeros((u.size, 1)), dist], axis=1)[:, : k0 + nxt0]
            return left_out, self._from_neighbors(X[c], with_self, zero, k0, nxt0)

        for c, (left_out, kept) in in_blocks(rows.size, _CHUNK, block):
            yield c, left_out, kept

    def _terms(self, X, rows=None):
        """Per chunk of ``X``: ``(slice, vals, taper, log_ratio)``.

        ``vals[b, q]`` is the first-order extension of ``phi`` from the ``q``-th nearest
        training sample of ``X[b]``, at distance ``e_q``, clamped to the range of ``phi``
        over that sample's stencil; ``taper = 1 - (e_q / e_{k+1})^2``
        measures it against the next neighbour's distance (a weight that reaches 0 where a
        neighbour leaves the ``k`` nearest) and ``log_ratio = log(d_q / d_1)``, of the
        locally scaled distances (module docstring).

        With ``rows``, ``X`` holds those training samples and each sample's own point is
        left out. Those leave-one-out estimates read the nearest other distinct points
        from the cloud's search (:meth:`_others`) instead of querying the index.
        """
        dom = self.cloud
        own = 0 if rows is None else 1
        k, nxt = self._sizes(own)
        for a in range(0, X.shape[0], _CHUNK):
            c = slice(a, min(X.shape[0], a + _CHUNK))
            if rows is None:
                ind, dist = dom.kneighbors(X[c], k + nxt)
            else:
                ind, dist = self._others(rows[c], k + nxt)
            yield (c, *self._from_neighbors(X[c], ind, dist, k, nxt))

    def _others(self, rows, count):
        """``(ind, dist)``: the ``count`` nearest other samples of the training samples
        ``rows``, from the graph, or from one wider search of every sample
        (:meth:`~ndboundary.PointCloud.sample_neighbors`) when the graph holds fewer.
        """
        ind, dist = self.cloud.sample_neighbors(count)
        u = self.cloud.unique_inverse[rows]
        return ind[u], dist[u]

    def _locally_scaled(self, ind, dist):
        """The distances ``dist`` to the neighbours ``ind`` in units of each neighbour's
        local scale (module docstring).
        """
        return dist / np.maximum(self._scale[ind], np.finfo(np.float64).tiny)

    def _from_neighbors(self, X, ind, dist, k, nxt):
        """``(vals, taper, log_ratio)`` of :meth:`_terms` from the neighbours ``ind`` of ``X``
        at distances ``dist`` (the ``k`` averaged, then the next one if ``nxt``).
        """
        far = np.maximum(dist[:, -1:], np.finfo(np.float64).tiny)
        if nxt:
            t = dist[:, :k] / far
            taper = np.clip(1.0 - t * t, 0.0, 1.0) + 1e-12  # all k tied with the next: even
        else:
            taper = np.ones((ind.shape[0], k))
        d = self._locally_scaled(ind, dist)[:, :k]
        near = d.min(axis=1, keepdims=True)
        guard = 1e-12 * np.maximum(d.max(axis=1, keepdims=True), np.finfo(np.float64).tiny)
        # for p > 0, a point on a training sample (d_1 = 0) takes that sample's value
        log_ratio = np.log(np.maximum(d, guard) / np.maximum(near, guard))
        ind = ind[:, :k]
        if self._ambient is not None:
            c, g = self._ambient
            vals = np.empty((ind.shape[0], k, c.shape[1]))
            ambient_values(c, g, ind.astype(np.int64, copy=False), X, self._lo, self._hi, vals)
            return vals, taper, log_ratio
        off = self.cloud.tangent_offsets(X, ind)  # (b, q, m)
        vals = self._phi_u[ind] + np.einsum("bqrm,bqm->bqr", self._grad_u[ind], off)
        return np.clip(vals, self._lo[ind], self._hi[ind]), taper, log_ratio
