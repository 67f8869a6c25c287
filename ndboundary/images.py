"""Relax a label image or volume directly: :func:`relax_image`."""

from __future__ import annotations

import numpy as np

from .domains.image import ImageGrid
from .pipeline import relax

__all__ = ["relax_image"]


def relax_image(labels, *, spacing=None, origin=None, direction=None, background=None, **params):
    """Relax the staircase boundaries of a 2-D label image or 3-D label volume.

    Parameters
    ----------
    labels : array_like of shape (n0, n1) or (n0, n1, n2)
        One label per pixel or voxel, any number of distinct labels (integers, booleans
        or strings). Not modified.
    spacing : float or sequence of float, optional
        The distance between pixel centres along each axis (default 1).
    origin : float or sequence of float, optional
        The centre of the first pixel (default 0): pixel ``index`` is centred at
        ``origin + index * spacing``, the NIfTI / ITK and scikit-image convention.
    direction : array_like of shape (dim, dim), optional
        The axes of an oblique scan (see :class:`~ndboundary.ImageGrid`): the outputs are
        then in its world coordinates.
    background : label, optional
        A label that is one more region of the partition (every pixel belongs to a
        region) but whose own boundary is not wanted: recorded as
        ``result.params["background"]`` (its index among ``result.classes``) for the
        writers and the command line, which then leave it out.
    **params
        Passed to :func:`~ndboundary.relax` (``lam``, ``smoothing``, ``band``, ...).

    Returns
    -------
    RelaxResult or RegionsResult
        On the :class:`~ndboundary.ImageGrid` of the image (``result.domain``): its
        ``level_set()``, ``interfaces()``, ``region_boundary(r)`` and
        ``region_measures()`` are in physical coordinates.

    Raises
    ------
    ValueError
        On an image that is not 2-D or 3-D, a bad spacing or origin, a background that is
        not one of the labels, or labels ``relax`` refuses (one class, NaN).

    Examples
    --------
    A disc of radius 6 pixels on a 24 x 24 image, with pixels 0.5 mm apart:

    >>> import numpy as np
    >>> from ndboundary import relax_image
    >>> i, j = np.indices((24, 24))
    >>> disc = (i - 11.5) ** 2 + (j - 11.5) ** 2 < 36
    >>> result = relax_image(disc, spacing=0.5)
    >>> curve = result.level_set()
    >>> curve.n_components(), round(curve.measure() / (2 * np.pi * 3.0), 2)
    (1, 1.0)
    """
    labels = np.asarray(labels)
    if labels.ndim not in (2, 3):
        raise ValueError(f"labels must be a 2-D image or a 3-D volume, got shape {labels.shape}")
    grid = ImageGrid(
        labels.shape,
        spacing=1.0 if spacing is None else spacing,
        origin=0.0 if origin is None else origin,
        direction=direction,
    )
    result = relax(grid, labels.reshape(-1), on="elements", **params)
    if background is not None:
        where = np.flatnonzero(result.classes == background)
        if where.size != 1:
            raise ValueError(f"background {background!r} is not one of the labels {result.classes.tolist()}")
        result.params["background"] = int(where[0])
    return result
