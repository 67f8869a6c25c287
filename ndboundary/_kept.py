"""Arrays that each thread keeps from one call to the next.

A Dask worker's allocator (glibc, with the ``MALLOC_TRIM_THRESHOLD_`` that Dask's nanny
sets) maps every array larger than 128 KiB afresh and hands it back to the system as
soon as it is freed, so that an array made at each call, or each block of rows, is
faulted in again page by page: predicting 100 000 rows there faulted in 27 MB of
temporaries. The per-block buffers of the predictions are kept here instead, once per
thread, for the thread's life. Threads of a pool made for one call let theirs go with
them.
"""

from __future__ import annotations

import threading

import numpy as np

__all__ = ["kept_array"]

_LOCAL = threading.local()


def kept_array(name, shape, dtype=np.float64):
    """An array of ``shape`` and ``dtype`` that the calling thread keeps under ``name``
    and hands back at its next request, holding whatever its last user left there.

    The array kept has at least ``shape[0]`` rows (a view of its first rows is returned)
    and is made anew when the request needs more rows, other trailing dimensions or
    another dtype. Each name serves one use at a time in a thread: a caller must be done
    with the array before asking for the same name again, and must not hand it out.

    Examples
    --------
    >>> from ndboundary._kept import kept_array
    >>> a = kept_array("example", (4, 3))
    >>> b = kept_array("example", (2, 3))
    >>> b.shape, bool(b.base is a.base)
    ((2, 3), True)
    """
    arrays = _LOCAL.__dict__.setdefault("arrays", {})
    shape = tuple(int(s) for s in shape)
    dtype = np.dtype(dtype)
    held = arrays.get(name)
    if held is None or held.dtype != dtype or held.shape[1:] != shape[1:] or held.shape[0] < shape[0]:
        held = arrays[name] = np.empty(shape, dtype=dtype)
    return held[: shape[0]]
