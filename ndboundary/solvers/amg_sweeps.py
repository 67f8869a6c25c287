"""Forward Gauss-Seidel sweeps that also return the residual they leave, for the V-cycle of
:func:`~ndboundary.solvers.amg.amg_preconditioner` (numba).

On a symmetric matrix the residual a forward sweep leaves needs no product with the
matrix. Row ``i``'s equation holds once the sweep has passed it, but for the later rows'
changes: ``r_i = -sum_{j > i} a_ij (x_j' - x_j)``, ``x`` before the sweep and ``x'``
after it. Each row scatters its own change to the earlier rows of its pattern (its
lower triangle, ``a_ji = a_ij``) as the sweep passes it. A V-cycle's pre-smoothing and the
residual it restricts thus read the matrix once instead of twice; its first sweep starts
from zero, so it reads only the lower triangle: half the matrix where it read it twice.
What it saves is the product: a sweep waits on each row's predecessor as much as on
memory, so half the matrix takes about as long as pyamg's sweep over all of it (the
README gives the times). The indices are read as unsigned, which spares numba's checks
for negative ones, which more than doubled its time.
"""

from __future__ import annotations

import numba
import numpy as np

from .._compiled import diagonal_slots
from .._kernels import kernel

__all__ = ["ForwardSweeps"]


@kernel("void(u4[::1], u4[::1], u4[::1], f4[::1], f4[::1], f4[::1], f4[::1], b1)")
@numba.njit(cache=True, nogil=True)
def _forward(indptr, indices, slots, data, b, x, r, from_zero):  # pragma: no cover - compiled
    """One forward sweep from ``x`` (zero for ``from_zero``: the upper triangle is not
    read), in place, and its residual into ``r``.
    """
    for i in range(b.size):
        start = indptr[i]
        diagonal = slots[i]
        s = b[i]
        for p in range(start, diagonal):
            s -= data[p] * x[indices[p]]
        if not from_zero:
            for p in range(diagonal + 1, indptr[i + 1]):
                s -= data[p] * x[indices[p]]
        value = s / data[diagonal]
        change = value - x[i]
        x[i] = value
        r[i] = 0.0
        for p in range(start, diagonal):
            r[indices[p]] -= data[p] * change


class ForwardSweeps:
    """Forward Gauss-Seidel sweeps on ``A x = b`` that return the residual they leave.

    Parameters
    ----------
    A : scipy.sparse.csr_matrix of shape (n, n), float32
        Symmetric, with 32-bit indices sorted in each row and a positive diagonal.

    Raises
    ------
    TypeError
        If ``A`` is not float32 with 32-bit indices.
    ValueError
        If its indices are not sorted, or a diagonal entry is missing or not positive.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> A = sp.csr_matrix(np.array([[4.0, -1.0, 0.0], [-1.0, 4.0, -1.0], [0.0, -1.0, 4.0]], dtype=np.float32))
    >>> b = np.ones(3, dtype=np.float32)
    >>> sweeps = ForwardSweeps(A)
    >>> x, r = sweeps.from_zero(b)
    >>> bool(np.allclose(r, b - A @ x, atol=1e-6))
    True
    >>> r = sweeps.sweep(b, x)  # a second sweep, x in place
    >>> bool(np.allclose(r, b - A @ x, atol=1e-6))
    True
    """

    def __init__(self, A):
        if A.dtype != np.float32 or A.indices.dtype != np.int32 or A.indptr.dtype != np.int32:
            raise TypeError("the sweeps run on float32 entries with 32-bit indices")
        if not A.has_sorted_indices:
            raise ValueError("the sweeps need A's column indices sorted in each row")
        n = A.shape[0]
        slots = np.empty(n, dtype=np.int64)
        diagonal_slots(A.indptr, A.indices, slots)
        if (slots < 0).any() or not (A.data[np.maximum(slots, 0)] > 0).all():
            raise ValueError("the sweeps need a positive diagonal entry on every row of A")
        self._arrays = (A.indptr.view(np.uint32), A.indices.view(np.uint32), slots.astype(np.uint32), A.data)

    def from_zero(self, b):
        """One sweep from ``x = 0``: ``(x, r)``, ``r = b - A x``, both float32."""
        x = np.zeros_like(b)
        r = np.empty_like(b)
        _forward(*self._arrays, b, x, r, True)
        return x, r

    def sweep(self, b, x):
        """One sweep from ``x``, in place: the residual ``b - A x`` it leaves."""
        r = np.empty_like(b)
        _forward(*self._arrays, b, x, r, False)
        return r
