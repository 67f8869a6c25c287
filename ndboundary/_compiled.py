"""Compiled loops (numba) for the hot spots of the field smoothing."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _sweep3(indptr, indices, data, A, B):  # pragma: no cover - compiled
    for i in range(A.shape[0]):
        x = 0.0
        y = 0.0
        z = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            w = data[p]
            x += w * A[j, 0]
            y += w * A[j, 1]
            z += w * A[j, 2]
        s = x * x + y * y + z * z
        if s > 0.0:
            s = 1.0 / np.sqrt(s)
        B[i, 0] = x * s
        B[i, 1] = y * s
        B[i, 2] = z * s


@numba.njit(cache=True, nogil=True)
def _sweep(indptr, indices, data, A, B):  # pragma: no cover - compiled
    d = A.shape[1]
    for i in range(A.shape[0]):
        for c in range(d):
            B[i, c] = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            w = data[p]
            for c in range(d):
                B[i, c] += w * A[j, c]
        s = 0.0
        for c in range(d):
            s += B[i, c] * B[i, c]
        if s > 0.0:
            s = 1.0 / np.sqrt(s)
        for c in range(d):
            B[i, c] *= s


def smooth_rows_compiled(W, X, passes):
    """``passes`` sweeps of ``X <- normalize_rows(W @ X)``, each row in one go.

    ``W`` is a CSR matrix, ``X`` an (n, d) array (not modified). Every sweep reads the
    previous sweep's rows only (Jacobi order), so the result does not depend on the row
    order; zero rows stay zero. Summing and renormalising a row in one loop reads the
    field once per sweep instead of the four passes of a sparse product and a
    renormalisation.
    """
    d = X.shape[1]
    # planar fields run through the 3-column loop with a zero third component
    sweep = _sweep3 if d in (2, 3) else _sweep
    indptr = W.indptr.astype(np.int64, copy=False)
    indices = W.indices.astype(np.int64, copy=False)
    data = W.data.astype(np.float64, copy=False)
    A = np.zeros((X.shape[0], 3 if d == 2 else d))
    A[:, :d] = X
    B = np.empty_like(A)
    for _ in range(passes):
        sweep(indptr, indices, data, A, B)
        A, B = B, A
    return A[:, :d].copy() if d == 2 else A
