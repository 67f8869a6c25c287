"""Which samples the classifier relaxes: the whole graph, or a band around each class boundary.

:func:`ndboundary.relax` can relax over the elements within a graph distance of the
jagged boundary only and fill phi beyond them with the signed graph distance
(:mod:`ndboundary.pipeline.band`). Whether that pays depends on where the samples lie.

In low dimension most of them lie far from the class boundary in units of the neighbour
distance ``h``, and the band saves most of the relaxation: with two features and 100 000
samples (``benchmarks/scale.py --data plane``), a fifth of them lie within 16 ``h`` of the
boundary, the relaxation runs 9 times faster (27 s of CPU down to 2.9 s), the whole fit
4.7 times (30.4 s down to 6.5 s, the neighbour search compiled), and the test
predictions do not change.

In higher dimension every sample lies within a few ``h`` of the boundary and the band
holds them all: on the 5-dimensional manifold of ``benchmarks/scale.py`` (100 000
samples in R^50, 15 neighbours) the farthest sample lies 9.3 ``h`` from it and half of
them within 1.5 ``h``; a band of 2 ``h`` still holds 73 % of the samples, saves a third of
the relaxation and changes 50 of 100 000 test predictions, and one of 10 ``h`` or more
holds every sample, so the relaxation is the whole graph's. The same holds for noisy
labels in any dimension: with 5 % of the labels of the two-feature data flipped, every
sample lies within 4.3 ``h`` of a boundary.

``band="auto"`` therefore asks for a band only where it can hold a minority of the
samples: ``n`` samples of intrinsic dimension ``m`` span about ``n^(1/m)`` neighbour
distances, and a band of half-width ``w`` around a boundary through them holds a share
of about ``2 w / n^(1/m)``. With ``w`` = 16 ``h``, two dimensions at 100 000 samples span
316 ``h`` (a band of a tenth), five dimensions 10 ``h`` (every sample). Where the share
would pass one half (:data:`AUTO_BAND_SPAN`), the graph is relaxed whole without
searching for the band, whose search alone (graph distances over every edge) took 3 to
6 s on the 5-dimensional manifold.

Up to :data:`AUTO_BAND_MIN_SAMPLES` samples the whole graph is relaxed: the relaxation is
short there (the 20 000 samples of ``benchmarks/scale.py``, all within 4.3 ``h`` of the
boundary, gain nothing), and the data sets of ``benchmarks/classify.py`` keep exactly
their results.
"""

from __future__ import annotations

from ..domains import PointCloud

__all__ = ["AUTO_BAND_MIN_SAMPLES", "AUTO_BAND_SPAN", "AUTO_BAND_WIDTH", "classifier_band"]

#: ``band="auto"``: the band's half-width in units of ``h``. With the classifier's
#: parameters, phi near the boundary then matches the whole graph's within 0.005 h on
#: average and 0.05 h at worst (``tests/test_pointcloud_band.py``).
AUTO_BAND_WIDTH = 16.0

#: ``band="auto"`` relaxes the whole graph up to this many samples.
AUTO_BAND_MIN_SAMPLES = 20_000

#: ``band="auto"`` asks for a band only where the samples span more than this many band
#: half-widths, ``n^(1/m) > AUTO_BAND_SPAN * AUTO_BAND_WIDTH``: the band would hold under
#: about half of them (module docstring).
AUTO_BAND_SPAN = 4.0


def classifier_band(band, domain):
    """The band width (in units of ``h``) the classifier relaxes with, or None for the whole graph.

    Parameters
    ----------
    band : "auto", float or None
        The classifier's ``band``: ``"auto"`` is :data:`AUTO_BAND_WIDTH` on a kNN graph of
        more than :data:`AUTO_BAND_MIN_SAMPLES` samples that span enough band widths in
        their intrinsic dimension (:data:`AUTO_BAND_SPAN`), the whole graph otherwise (on
        a Delaunay complex too: its band converges more slowly with the width).
    domain : Domain
        The graph over the training samples.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> from ndboundary.learn.band import classifier_band
    >>> cloud = PointCloud(np.random.default_rng(0).normal(size=(100, 2)))
    >>> classifier_band("auto", cloud) is None, classifier_band(8.0, cloud)
    (True, 8.0)
    """
    if band != "auto":
        return band
    if not isinstance(domain, PointCloud) or domain.n_vertices <= AUTO_BAND_MIN_SAMPLES:
        return None
    span = domain.n_vertices ** (1.0 / max(domain.intrinsic_dim, 1))
    return AUTO_BAND_WIDTH if span > AUTO_BAND_SPAN * AUTO_BAND_WIDTH else None
