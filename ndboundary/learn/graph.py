"""The graph the classifier relaxes over: a kNN point cloud or a Delaunay complex."""

from __future__ import annotations


from ..domains import DelaunayComplex, PointCloud
from ..domains.delaunay import DELAUNAY_MAX_DIM

__all__ = ["AUTO_NEIGHBORS", "AUTO_NEIGHBORS_LARGE", "AUTO_NEIGHBORS_MAX_SAMPLES", "build_graph"]

#: ``n_neighbors="auto"``: this many neighbours up to :data:`AUTO_NEIGHBORS_MAX_SAMPLES`
#: samples, then :data:`AUTO_NEIGHBORS_LARGE`. On a few hundred noisy samples the wider
#: stencil steadies the tangent gradients; from 2 500 samples on, 15 neighbours gave the
#: same test accuracy (the README's classifier section has the draws) in half the time.
AUTO_NEIGHBORS = 40
AUTO_NEIGHBORS_MAX_SAMPLES = 2_000
AUTO_NEIGHBORS_LARGE = 15


def build_graph(X, graph, n_neighbors, lam, *, distinct, intrinsic_dim=None, random_state=None, search_neighbors=None):
    """The classifier's domain over the samples ``X``: ``(domain, n_neighbors, lam)``.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        The scaled training samples.
    graph : {"knn", "delaunay", "auto"}
        ``"auto"``: Delaunay for 2 or 3 features and distinct samples, kNN otherwise.
    n_neighbors : int or "auto"
        Neighbours per sample of a kNN graph (``"auto"``: :data:`AUTO_NEIGHBORS` up to
        :data:`AUTO_NEIGHBORS_MAX_SAMPLES` samples, :data:`AUTO_NEIGHBORS_LARGE` beyond).
    lam : float
        The boundary weight asked for.
    distinct : bool
        Whether the samples are distinct (a Delaunay complex needs them to be).
    search_neighbors : int or None
        Neighbours a kNN graph searches per sample and keeps for its extension
        (:class:`~ndboundary.PointCloud`'s ``search_neighbors``).

    Returns
    -------
    domain : PointCloud or DelaunayComplex
    n_neighbors : int
        Neighbours per sample of the graph built (0 for a Delaunay complex).
    lam : float
        The boundary weight to relax with: on a complete kNN graph (fewer distinct
        samples than ``n_neighbors + 1``) scaled by ``n_neighbors / (n_distinct - 1)``,
        as :mod:`ndboundary.learn.classifier` explains.

    Raises
    ------
    ValueError
        For ``graph="delaunay"`` outside 2 to 6 features.
    """
    if graph == "auto":
        graph = "delaunay" if 2 <= X.shape[1] <= 3 and distinct and X.shape[0] > X.shape[1] + 1 else "knn"
    if graph == "delaunay":
        if not 2 <= X.shape[1] <= DELAUNAY_MAX_DIM:
            raise ValueError(
                f"graph='delaunay' needs 2 to {DELAUNAY_MAX_DIM} features, got {X.shape[1]}; use graph='knn'"
            )
        return DelaunayComplex(X), 0, lam
    k = n_neighbors
    if k == "auto":
        k = AUTO_NEIGHBORS if X.shape[0] <= AUTO_NEIGHBORS_MAX_SAMPLES else AUTO_NEIGHBORS_LARGE
    cloud = PointCloud(
        X, n_neighbors=k, intrinsic_dim=intrinsic_dim, random_state=random_state, search_neighbors=search_neighbors
    )
    return cloud, cloud.n_neighbors, lam * k / cloud.n_neighbors
