"""The parameters of the relaxation: defaults, the paper's settings, and their validation."""

from __future__ import annotations

from .._validation import check_nonnegative_int, check_positive

__all__ = [
    "DEFAULT_LAM",
    "DEFAULT_MU",
    "DEFAULT_RTOL",
    "DEFAULT_SMOOTHING",
    "INTEGRATION_RTOL_MAX",
    "INTEGRATION_RTOL_SCALE",
    "PAPER",
    "check_params",
    "integration_rtol",
]

#: Default weight of the boundary term (dimensionless, see :mod:`.integration`): strong
#: enough to hold the level set on zeta through many smoothing passes (paper Fig. 8:
#: ``lam >= 0.5`` stays faithful whatever the passes).
DEFAULT_LAM = 2.0
#: Default number of field smoothing passes: many more than the paper's 3-5, which leave
#: ripples on jittered grids; the boundary term keeps the level set in place.
DEFAULT_SMOOTHING = 60
#: Default weight of the first-order fit ``||grad phi - X'||^2`` added to the paper's
#: Laplacian fit: it anchors phi to the field far from zeta, where the squared
#: Laplacian alone lets phi bend freely (thin parts of a surface far from the boundary).
DEFAULT_MU = 0.03
#: Default relative residual of the linear solves. Loosening it from 1e-10 to 1e-7 moved
#: the level set by at most 2.2e-5 h on triangles, surfaces, Voronoi polygons, tetrahedra
#: and hexahedra, and took the integration of a tetrahedral band from 59 iterations to
#: 43. At 1e-6 the heat's trust floor, ``max(1e-5, 100 rtol)``, rises and the level set
#: moved by up to 3e-3 h on hexahedra.
DEFAULT_RTOL = 1e-7
#: The squared-Laplacian integration solves to ``INTEGRATION_RTOL_SCALE`` times ``rtol``,
#: up to :data:`INTEGRATION_RTOL_MAX` (:func:`integration_rtol`). At 1e-4 against 1e-10,
#: phi near 1/2 moved by at most 3e-4 h on Voronoi polygons, tetrahedra, hexahedra and a
#: voxel ball, and 1.5e-3 h on a ball on slices 6.7 times thicker than wide (a triangle
#: mesh's direct solve does not move), a hundredth of the band's own bound on the level
#: set's change (0.05 h at most), for 15-22 % fewer iterations than at 1e-5 and half those
#: at 1e-10 (``benchmarks/integration_rtol.py --also 1e-4``).
INTEGRATION_RTOL_SCALE = 1000.0
#: See :data:`INTEGRATION_RTOL_SCALE`.
INTEGRATION_RTOL_MAX = 1e-4
#: The paper's own setting (Fig. 8, Table 1): 3 passes, its unweighted form, no first-order term.
#: Its pins at zeta's vertices on simplices are a switch of their own
#: (:data:`~ndboundary.pipeline.boundary.FACET_CENTRE_PINS`).
PAPER = {"lam": 0.5, "smoothing": 3, "form": "plain", "mu": 0.0}


def check_params(*, on, lam, smoothing, mu, t, form, rtol, solver, band=None):
    """Validate the parameters of :func:`~ndboundary.relax`; returns them normalised as a dict.

    Examples
    --------
    >>> from ndboundary.pipeline.params import check_params
    >>> p = check_params(on="elements", lam=2.0, smoothing=60, mu=0.03, t=None, form="mass", rtol=1e-10, solver="auto")
    >>> p["t"], p["smoothing"]  # t defaults to 1 (in units of h^2)
    (1.0, 60)
    >>> check_params(on="edges", lam=2.0, smoothing=60, mu=0.03, t=None, form="mass", rtol=1e-10, solver="auto")
    Traceback (most recent call last):
    ...
    ValueError: on must be 'elements' or 'vertices', got 'edges'
    """
    if on not in ("elements", "vertices"):
        raise ValueError(f"on must be 'elements' or 'vertices', got {on!r}")
    if form not in ("mass", "plain", "gradient"):
        raise ValueError(f"form must be 'mass', 'plain' or 'gradient', got {form!r}")
    if solver not in ("auto", "pcg", "direct"):
        raise ValueError(f"solver must be 'auto', 'pcg' or 'direct', got {solver!r}")
    if band is not None and not (isinstance(band, str) and band == "auto"):
        if isinstance(band, str):
            raise ValueError(f"band must be None, 'auto' or a width in units of h, got {band!r}")
        band = check_positive(band, "band")
    return {
        "band": band,
        "on": on,
        "lam": check_positive(lam, "lam"),
        "smoothing": check_nonnegative_int(smoothing, "smoothing"),
        "mu": check_positive(mu, "mu", allow_zero=True),
        "t": 1.0 if t is None else check_positive(t, "t"),
        "form": form,
        "rtol": check_positive(rtol, "rtol"),
        "solver": solver,
    }


def integration_rtol(rtol):
    """The relative residual the squared-Laplacian integration solves to, for the heat's
    ``rtol``: ``INTEGRATION_RTOL_SCALE * rtol``, but no looser than
    :data:`INTEGRATION_RTOL_MAX`, nor tighter than ``rtol``.

    Examples
    --------
    >>> from ndboundary.pipeline.params import integration_rtol
    >>> [f"{integration_rtol(rtol):.0e}" for rtol in (1e-7, 1e-10, 1e-4)]
    ['1e-04', '1e-07', '1e-04']
    """
    return max(rtol, min(INTEGRATION_RTOL_SCALE * rtol, INTEGRATION_RTOL_MAX))
