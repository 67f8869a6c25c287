"""Checks of a domain before it is relaxed: elements too thin to trust the result."""

from __future__ import annotations

import sys
import warnings

import numpy as np

from ..domains.base import MeshQualityWarning

__all__ = ["ANISOTROPIC_MEDIAN", "FLAT_ASPECT", "check_element_shapes", "outside_stacklevel"]

#: A domain whose median element has an aspect ratio above this is too anisotropic for
#: the isotropic heat and smoothing (:class:`~ndboundary.domains.MeshQualityWarning`).
ANISOTROPIC_MEDIAN = 10.0
#: Elements with an aspect ratio above this are nearly flat: the solves lose accuracy.
FLAT_ASPECT = 1e4


def check_element_shapes(domain, element_ids=None):
    """Warn (:class:`~ndboundary.domains.MeshQualityWarning`) when the domain's elements are
    too thin to trust the relaxation, naming the worst elements and their aspect ratios.

    The warning names the line that called into ndboundary, whatever the depth of the
    steps between (a band, a region among several).

    ``element_ids``, when ``domain`` was cut from the caller's (a band), holds each of its
    elements' index in the caller's domain: the warning names those.

    Examples
    --------
    >>> import warnings
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.checks import check_element_shapes
    >>> grid = kuhn_grid(10, 2)
    >>> squashed = type(grid)(grid.points * [1, 1e-2], grid.simplices)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_element_shapes(grid)
    ...     check_element_shapes(squashed)
    >>> len(caught), "aspect ratio" in str(caught[0].message)
    (1, True)
    """
    ratios = domain.aspect_ratios()
    if ratios is None or ratios.size == 0:
        return
    median = float(np.median(ratios))
    if median <= ANISOTROPIC_MEDIAN and ratios.max() <= FLAT_ASPECT:
        return
    top = np.argpartition(ratios, -3)[-3:] if ratios.size > 3 else np.arange(ratios.size)
    worst = top[np.argsort(ratios[top])[::-1]]
    ids = np.arange(ratios.size) if element_ids is None else np.asarray(element_ids)
    named = ", ".join(f"{int(ids[e])} ({ratios[e]:.3g})" for e in worst)
    why = (
        f"the median element has an aspect ratio of {median:.3g}: the heat and the field "
        "smoothing are isotropic, so they blur what lies across such thin elements"
        if median > ANISOTROPIC_MEDIAN
        else f"{int((ratios > FLAT_ASPECT).sum())} element(s) are nearly flat, and the linear solves "
        "lose accuracy on them"
    )
    warnings.warn(
        f"ill-shaped elements: {why}; the relaxed boundary may not follow the labels. Worst "
        f"elements (aspect ratio): {named}. Remesh, or scale the coordinates to make the "
        "elements well shaped.",
        MeshQualityWarning,
        stacklevel=outside_stacklevel(),
    )


def outside_stacklevel():
    """The ``stacklevel`` that makes a warning raised by this function's caller name the
    first frame outside ndboundary: the user's call.
    """
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] == "ndboundary":
        frame, level = frame.f_back, level + 1
    return level
