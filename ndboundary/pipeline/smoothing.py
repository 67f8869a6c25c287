"""Step 3: the field is smoothed by a few passes of averaging over neighbouring elements.

Each pass averages every element's vector with its neighbours' and renormalises, in
Jacobi order (one sparse product per pass, so the result does not depend on the element
order). How vectors are averaged is the domain's (:meth:`~ndboundary.Domain.smooth_field`):
uniform weights over facet neighbours on meshes, transport between tangent frames on a
kNN graph.
"""

from __future__ import annotations

__all__ = ["smooth"]


def smooth(work, X, passes, groups=None):
    """``passes`` smoothing passes of the field ``X`` (not modified) on the padded domain;
    with ``groups``, within each group of elements only (:meth:`~ndboundary.Domain.smooth_field`).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.smoothing import smooth
    >>> mesh = kuhn_grid(10, 2)
    >>> X = np.random.default_rng(0).normal(size=(mesh.n_elements, 2))
    >>> Xs = smooth(mesh, X, 10)
    >>> Xs.shape, bool(np.allclose(np.linalg.norm(Xs, axis=1), 1.0)), smooth(mesh, X, 0) is X
    ((200, 2), True, True)
    """
    if not passes:
        return X
    return work.smooth_field(X, passes) if groups is None else work.smooth_field(X, passes, groups=groups)
