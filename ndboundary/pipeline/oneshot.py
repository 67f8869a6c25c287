"""The one-shot relaxation, :func:`relax`: a :class:`~ndboundary.Relaxer` that keeps nothing."""

from __future__ import annotations

from .params import DEFAULT_LAM, DEFAULT_MU, DEFAULT_RTOL, DEFAULT_SMOOTHING
from .relaxer import Relaxer

__all__ = ["relax"]


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
    rtol=DEFAULT_RTOL,
    solver="auto",
    band="auto",
    verbose=False,
):
    """Relax the jagged boundary between two labelled regions into the level set ``phi = 1/2``.

    The paper's four steps (:mod:`ndboundary.pipeline`): heat from zeta, the unit field
    that crosses it, the field smoothed, and phi integrated from it by least squares.
    This is the one-shot form of :meth:`Relaxer.relax`: nothing is kept for a next call.

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
        zeta than on a regular simplicial grid (``params["lam_scale"]`` of the result).
        Larger stays closer to the jagged boundary; the default holds the level set on
        zeta through the default smoothing.
    smoothing : int, default=60
        Number of field smoothing passes. The paper uses 3-5, which leaves visible
        ripples; more passes relax further while ``lam`` keeps the boundary in place.
    mu : float, default=0.03
        Weight of the first-order fit ``||grad phi - X'||^2``; 0 is the paper's energy. A
        small value anchors phi far from zeta, where the squared Laplacian leaves it free.
    t : float, optional
        Diffusion time in units of ``h^2`` (``h`` = mean edge length); default 1, the
        heat method's choice.
    form : {"mass", "plain", "gradient"}, default="mass"
        ``"mass"`` integrates with the consistent ``K M^{-1} K``; ``"plain"`` with the
        paper's unweighted ``K^T K`` (both in units of ``h``); ``"gradient"`` fits
        ``grad phi`` to the field by least squares, ``(K + lam S^T S) phi``, without
        ``mu``: far cheaper to solve on neighbour graphs, where it is the classifier's
        form, but kinked at the points of a sparse zeta
        (:mod:`ndboundary.pipeline.integration`).
    pad : bool, default=True
        Split the elements all of whose vertices receive heat (paper section 4). False
        leaves them whole: they take the mean field of their neighbours
        (:func:`~ndboundary.pipeline.field.fill_flat`).
    rtol : float, default=1e-7
        Relative residual the heat solve must reach
        (:data:`~ndboundary.pipeline.params.DEFAULT_RTOL`: the level set moves by less
        than 1e-4 h from there to 1e-10); the squared-Laplacian integration solves to
        ``1000 rtol``, but no looser than 1e-4
        (:func:`~ndboundary.pipeline.params.integration_rtol`), the first-order form to
        ``rtol``. The heat is trusted down to ``max(1e-5, 100 rtol)`` of its maximum;
        below, the field follows the graph distance to zeta.
    solver : {"auto", "pcg", "direct"}, default="auto"
        How to solve the integration system (see :func:`ndboundary.solvers.solve_integration`).
    band : "auto", float or None, default="auto"
        Relax only the elements within this graph distance of zeta, in units of ``h``,
        and fill phi outside them with the band-edge value plus the signed graph distance
        in units of ``h`` (:mod:`ndboundary.pipeline.band`): beyond linear passes to find
        zeta and the band, the cost follows the band, not the domain. ``"auto"``
        (:func:`~ndboundary.pipeline.band.band_width`): 8 mean edge lengths on triangles, 6
        on tetrahedra and up, 12 on quads, polygons and hexahedra (the domain's
        ``band_reach``) with the default parameters, wider for a weaker boundary term (times
        ``(2 / (lam * lam_scale))^(3/4)`` when the boundary weight falls below the
        default's) or fewer smoothing passes (times ``(60 / smoothing)^(1/2)`` below 60);
        the whole domain when it has fewer than 20 000 vertices, when the band would hold
        over 70 % of the elements, when ``mu = 0`` (nothing screens phi), with fewer than
        10 smoothing passes, or when the domain cannot be cut
        (:meth:`~ndboundary.Domain.subdomain`). None relaxes the whole domain.
    verbose : bool, default=False
        Print each step's time to stderr as it ends.

    Returns
    -------
    RelaxResult

    Examples
    --------
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, flower
    >>> mesh = kuhn_grid(40, 2, jitter=0.25, random_state=0)
    >>> result = relax(mesh, label_by(mesh, flower), on="elements")
    >>> curve = result.level_set()
    >>> curve.is_closed(), curve.n_components()
    (True, 1)
    """
    return Relaxer(domain, _keep=False).relax(
        labels,
        on=on,
        lam=lam,
        smoothing=smoothing,
        mu=mu,
        t=t,
        form=form,
        pad=pad,
        rtol=rtol,
        solver=solver,
        band=band,
        verbose=verbose,
    )
