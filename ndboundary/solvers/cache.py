"""Reuse of a factorisation between solves: :class:`FactorCache`, and the content
digest that keys it (and PARDISO's kept ordering).
"""

from __future__ import annotations

import hashlib
import os

import numpy as np
import scipy.sparse as sp

__all__ = ["FactorCache", "cached", "digest", "orderings_of"]


class FactorCache:
    """The last factorisation or preconditioner of a solve, kept for the next one.

    One entry, keyed by the content of the matrix it factorises (so a changed matrix is
    never solved with a stale factor), and the last METIS ordering PARDISO computed,
    keyed by the sparsity pattern it orders (the integration matrix of a mesh has one
    pattern whatever the labels and parameters). A :class:`~ndboundary.Relaxer` owns one;
    nothing is kept between solves without it.

    Attributes
    ----------
    orderings : dict
        The kept PARDISO ordering, passed as ``orderings`` to
        :func:`~ndboundary.solvers.factorize_spd`.
    nbytes : int
        Memory the kept entry holds: the factor's entries where the backend reports them,
        else the resident memory its construction added (Linux), else 0.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> from ndboundary.solvers import FactorCache, solve_integration
    >>> cache = FactorCache()
    >>> K = sp.csr_matrix([[1.0, -1.0], [-1.0, 1.0]])
    >>> S = sp.csr_matrix([[1.0, 0.0]])
    >>> phi, info = solve_integration(K, [1.0, 1.0], S, 1.0, [0.5, 0.0], cache=cache)
    >>> len(cache) == 1 and cache.nbytes >= 0
    True
    """

    def __init__(self, keep_factor=True):
        self.keep_factor = keep_factor  # False: only the squared operator and orderings are kept
        self._entry = None
        self._squared = None  # (key, K M^-1 K + mu K): the part of Q that no labelling changes
        self.orderings = {}
        self.nbytes = 0

    def __len__(self):
        return int(self._entry is not None)

    def get(self, kind, A, build):
        """The cached value for ``(kind, A)``, or ``build(A)`` cached in its place (not
        cached, and ``A`` not even compared, without ``keep_factor``).
        """
        if not self.keep_factor:
            return build(A)
        key = _key(kind, A)
        entry = self._entry  # one (key, value) tuple: safe to read from any thread
        if entry is not None and entry[0] == key:
            return entry[1]
        self._entry, self.nbytes = None, 0  # free the old factor before building the new one
        before = _resident_bytes()
        value = build(A)
        self.nbytes = _factor_bytes(value, max(0, _resident_bytes() - before))
        self._entry = (key, value)
        return value

    def squared(self, K, mass, mu, build):
        """``build()``, the integration matrix's ``K M^{-1} K + mu K``, or the one kept for
        the same ``K``, ``mass`` and ``mu`` (compared by content): the relaxations of
        several labellings of one domain share it, and only their constraint rows differ.
        """
        K = sp.csr_matrix(K)
        key = digest(("squared", K.shape, float(mu)), K.indptr, K.indices, K.data, np.asarray(mass))
        kept = self._squared
        if kept is not None and kept[0] == key:
            return kept[1]
        value = build()
        self._squared = (key, value)
        return value

    def clear(self, orderings=True):
        """Free the kept factorisation and squared operator (and, by default, the kept ordering)."""
        self._entry = None
        self._squared = None
        self.nbytes = 0
        if orderings:
            self.orderings.clear()


def digest(tag, *arrays):
    """A content key of ``arrays`` (their sizes and bytes) and the hashable ``tag``.

    Equal contents give equal keys whatever the arrays' memory layout; the sizes take
    part so that two splits of the same bytes into arrays differ.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.arange(4)
    >>> digest("x", a) == digest("x", a.copy()), digest("x", a) == digest("y", a)
    (True, False)
    >>> digest("x", a[:2], a[2:]) == digest("x", a[:3], a[3:])
    False
    """
    h = hashlib.blake2b(digest_size=16)
    h.update(repr((tag, [a.size for a in arrays])).encode())
    for arr in arrays:
        h.update(np.ascontiguousarray(arr).view(np.uint8))
    return h.hexdigest()


def _key(kind, A):
    A = sp.csr_matrix(A)
    return digest((kind, A.shape), A.indptr, A.indices, A.data)


def _resident_bytes():
    """Resident memory of this process (Linux), else 0."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return 0


def _factor_bytes(solve, measured):
    """Bytes held by a factor's solve function: the ``factor_nbytes`` its object reports
    (:class:`~ndboundary.solvers.pardiso.PardisoFactor`), else ``measured``.
    """
    nbytes = getattr(getattr(solve, "__self__", None), "factor_nbytes", None)
    return measured if nbytes is None else nbytes


def cached(kind, A, build, cache):
    """``cache.get(kind, A, build)``, or ``build(A)`` without a cache (None).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> cached("x", sp.identity(2, format="csr"), lambda A: A.nnz, None)
    2
    """
    return build(A) if cache is None else cache.get(kind, A, build)


def orderings_of(cache):
    """Where PARDISO keeps its orderings in ``cache`` (None without a cache).

    Examples
    --------
    >>> orderings_of(None) is None, orderings_of(FactorCache()) == {}
    (True, True)
    """
    return None if cache is None else cache.orderings
