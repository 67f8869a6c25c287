"""Per-element vector fields: renormalisation and the averaging sweeps of the field smoothing."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["COMPILED_SMOOTHING_MIN_ROWS", "normalize_rows", "smooth_rows"]

#: From this many field rows, :func:`smooth_rows` runs a compiled loop (numba) that sums
#: and renormalises each row in one go, every sweep in one call below two threads' worth
#: of rows: half the time of the sparse products on a band of 20 000 elements, with the
#: same numbers for fields of 2 and 3 components (to rounding beyond; ``benchmarks/table1.py``
#: times the step). Built at install, it costs no compilation; on the smallest fields the
#: products are as fast.
COMPILED_SMOOTHING_MIN_ROWS = 2_000


def normalize_rows(X):
    """Scale the rows of ``X`` to unit length in place; zero rows stay zero. Returns ``X``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.fields import normalize_rows
    >>> normalize_rows(np.array([[3.0, 4.0], [0.0, 0.0]])).round(12).tolist()
    [[0.6, 0.8], [0.0, 0.0]]
    """
    scale = np.sqrt(np.einsum("ij,ij->i", X, X))
    zero = ~(scale > 0)
    if zero.any():
        scale[zero] = np.inf
    np.divide(1.0, scale, out=scale)
    X *= scale[:, None]
    return X


def smooth_rows(W, X, passes, *, plus_identity=False):
    """``passes`` sweeps of ``X <- normalize_rows(W @ X)`` in Jacobi order (``W + I`` with
    ``plus_identity``: each row averaged with itself, without forming the sum).

    Each sweep reads only the previous sweep's rows, so the result does not depend on
    the row order. ``X`` is not modified.

    Parameters
    ----------
    W : sparse matrix of shape (n, n)
        The averaging weights of one sweep.
    X : ndarray of shape (n, d)
    passes : int
    plus_identity : bool, default=False
        Average with ``W + I`` instead of ``W``.

    Returns
    -------
    ndarray of shape (n, d)

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary.fields import smooth_rows
    >>> W = sp.csr_matrix(np.ones((2, 2)))
    >>> smooth_rows(W, np.array([[1.0, 0.0], [0.0, 1.0]]), 1).round(4).tolist()
    [[0.7071, 0.7071], [0.7071, 0.7071]]
    """
    W = sp.csr_matrix(W)
    if passes == 0:
        return X
    if X.shape[0] >= COMPILED_SMOOTHING_MIN_ROWS:
        from ._compiled import smooth_rows_compiled

        if not W.has_sorted_indices:
            W = W.sorted_indices()  # a copy: the caller's matrix is left as it is
        return smooth_rows_compiled(W, X, passes, plus_identity)
    if plus_identity:
        W = (W + sp.identity(W.shape[0], format="csr")).tocsr()
    Xs = X
    for _ in range(passes):
        Xs = normalize_rows(W @ Xs)
    return Xs
