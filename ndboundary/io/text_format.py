"""Compiled (numba) text of the writers: rows of integers, and rows of doubles as ``%.17g`` writes them.

:func:`points_text` gives the bytes of ``line_format % tuple(row)`` for every row, with
``%.17g`` fields: 17 significant digits, correctly rounded (ties to even), in fixed
notation for decimal exponents -4..16 and exponential notation otherwise, trailing zeros
dropped. The digits of ``m * 2**e`` are those of ``m * 5**k * 2**(e + k)`` shifted right,
exact in 128-bit arithmetic for the magnitudes ``1e-9 <= |x| < 2**49`` (every
coordinate of a mesh in common units); other values are formatted by Python.
"""

from __future__ import annotations

import re

import numba
import numpy as np

from .._kernels import kernel
from . import common
from .common import flat_rows
from .text_numbers import mul64, njit_inline

__all__ = ["format_index_rows", "points_text", "rows_text"]

_POW5 = np.array([5**k for k in range(28)], dtype=np.uint64)
_E16, _E17 = np.uint64(10**16), np.uint64(10**17)
_U0, _U1, _U10, _U48, _U52, _U64 = (np.uint64(k) for k in (0, 1, 10, 48, 52, 64))
_ALL64 = np.uint64(2**64 - 1)
_FIELD = re.compile(r"%\.17g")


@njit_inline
def _shift_round(hi, lo, r):  # pragma: no cover - compiled
    """``(hi * 2**64 + lo) / 2**r`` rounded to the nearest integer, ties to even, for ``1 <= r <= 127``.

    Returns ``(value, before, fits)``: the value rounded and truncated, and whether they
    fit in 64 bits.
    """
    if r < 64:
        ur = np.uint64(r)
        if hi >> ur != _U0:
            return _U0, _U0, False
        q = (lo >> ur) | (hi << (_U64 - ur))
        half = (lo >> (ur - _U1)) & _U1
        sticky = lo & ((_U1 << (ur - _U1)) - _U1)
    elif r == 64:
        q, half, sticky = hi, lo >> np.uint64(63), lo & (_ALL64 >> _U1)
    else:
        ur = np.uint64(r - 64)
        q = hi >> ur
        half = (hi >> (ur - _U1)) & _U1
        sticky = (hi & ((_U1 << (ur - _U1)) - _U1)) | lo
    rounded = q + _U1 if half == _U1 and (sticky != _U0 or q & _U1 == _U1) else q
    return rounded, q, rounded >= q


@njit_inline
def _digits17(bits, x):  # pragma: no cover - compiled
    """The 17 significant digits of ``|x|`` (``1e-9 <= |x| < 2**49``) correctly rounded, and the decimal exponent."""
    m = (bits & np.uint64(0x000FFFFFFFFFFFFF)) | (_U1 << _U52)
    e = int((bits >> _U52) & np.uint64(0x7FF)) - 1075
    exp10 = ((e + 52) * 78913) >> 18  # floor(log2|x| * log10(2)): at most one below floor(log10|x|)
    for _ in range(4):
        k = 16 - exp10
        if k < 0 or k >= _POW5.size or not 1 <= -(e + k) <= 127:
            break
        hi, lo = mul64(m, _POW5[k])
        digits, before, fits = _shift_round(hi, lo, -(e + k))
        if not fits or before >= _E17:
            exp10 += 1
        elif before < _E16:
            exp10 -= 1
        elif digits == _E17:  # rounding carried into an 18th digit
            return _E16, exp10 + 1
        else:
            return digits, exp10
    return _U0, 0  # not reached for the magnitudes above


@njit_inline
def _write_g17(out, at, bits, x, scratch):  # pragma: no cover - compiled
    """Write ``"%.17g" % x`` at ``out[at]`` (``x`` zero or ``1e-9 <= |x| < 2**49``); returns the new end, or -1."""
    if bits >> np.uint64(63) == _U1:
        out[at] = 45
        at += 1
    if x == 0.0:
        out[at] = 48
        return at + 1
    digits, exp10 = _digits17(bits, x)
    if digits == _U0:
        return -1
    for i in range(16, -1, -1):
        scratch[i] = _U48 + digits % _U10
        digits //= _U10
    n = 17
    while scratch[n - 1] == 48:
        n -= 1
    if exp10 >= 0:  # fixed, with an integer part (exp10 < 15 here)
        out[at : at + exp10 + 1] = scratch[: exp10 + 1]
        at += exp10 + 1
        if n > exp10 + 1:
            out[at] = 46
            out[at + 1 : at + n - exp10] = scratch[exp10 + 1 : n]
            at += n - exp10
    elif exp10 >= -4:  # fixed, 0.000ddd
        out[at], out[at + 1] = 48, 46
        at += 2
        out[at : at - exp10 - 1] = 48
        at += -exp10 - 1
        out[at : at + n] = scratch[:n]
        at += n
    else:  # d.ddde-XX
        out[at] = scratch[0]
        at += 1
        if n > 1:
            out[at] = 46
            out[at + 1 : at + n] = scratch[1:n]
            at += n
        out[at], out[at + 1], out[at + 2], out[at + 3] = 101, 45, 48 + (-exp10) // 10, 48 + (-exp10) % 10
        at += 4
    return at


@kernel("u1[::1](u8[:, ::1], f8[:, ::1], b1[:, ::1], u1[::1], i8[::1], u1[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _format_floats(bits, values, easy, pieces, piece_ends, hard_text, hard_ends):  # pragma: no cover - compiled
    """The text of rows of doubles: piece ``j`` (of ``pieces``, ends ``piece_ends``) before value ``j`` of a
    row, the last piece after it. Values not ``easy`` are copied from ``hard_text`` (their Python text, ends
    ``hard_ends``). An empty result when a value was not formatted.
    """
    n_rows, n_cols = values.shape
    out = np.empty(n_rows * (pieces.size + 24 * n_cols) + hard_text.size, dtype=np.uint8)
    scratch = np.empty(17, dtype=np.uint8)
    at, h, start = 0, 0, 0
    for i in range(n_rows):
        for j in range(n_cols + 1):
            a, b = piece_ends[j], piece_ends[j + 1]
            out[at : at + b - a] = pieces[a:b]
            at += b - a
            if j == n_cols:
                break
            if easy[i, j]:
                at = _write_g17(out, at, bits[i, j], values[i, j], scratch)
                if at < 0:
                    return out[:0]
            else:
                end = hard_ends[h]
                out[at : at + end - start] = hard_text[start:end]
                at += end - start
                start, h = end, h + 1
    return out[:at]


def points_text(points, line_format) -> str:
    r"""The lines ``line_format % tuple(row)`` of the rows of a float array, every field ``%.17g``.

    The text ``np.savetxt`` writes with the same format, made in one compiled pass (by
    Python's ``%`` below :data:`~.common.FAST_MIN_VALUES` values, or for other formats).

    Parameters
    ----------
    points : array-like of shape (n, k)
    line_format : str
        ASCII text with ``k`` fields ``%.17g`` (``"v %.17g %.17g %.17g\n"``).

    Examples
    --------
    >>> points_text([[0.5, 1.0, -0.0], [1e-5, 123.25, 1e300]], "v %.17g %.17g %.17g\n")
    'v 0.5 1 -0\nv 1.0000000000000001e-05 123.25 1.0000000000000001e+300\n'
    """
    values = np.ascontiguousarray(points, dtype=np.float64)
    if values.size == 0:
        return ""
    pieces = _FIELD.split(line_format)
    fields = len(pieces) == values.shape[1] + 1 and line_format.isascii() and "%" not in "".join(pieces)
    if not fields or values.size < common.FAST_MIN_VALUES:
        return (line_format * values.shape[0]) % tuple(values.ravel().tolist())
    size = np.abs(values)
    easy = (values == 0) | ((size >= 1e-9) & (size < 2.0**49))
    hard = [format(v, ".17g") for v in values[~easy].tolist()]  # as ``%.17g`` formats them
    hard_text = "".join(hard).encode("ascii")
    hard_ends = np.cumsum([len(h) for h in hard], dtype=np.int64)
    text = _format_floats(
        values.view(np.uint64),
        values,
        easy,
        np.frombuffer("".join(pieces).encode("ascii"), dtype=np.uint8),
        np.cumsum([0] + [len(p) for p in pieces], dtype=np.int64),
        np.frombuffer(hard_text, dtype=np.uint8),
        hard_ends,
    )
    if text.size == 0:  # not reached: every easy value is formatted
        return (line_format * values.shape[0]) % tuple(values.ravel().tolist())
    return text.tobytes().decode("ascii")


@kernel("u1[::1](i8[::1], i8[::1], i8, u1[::1], b1)")
@numba.njit(cache=True, nogil=True)
def _format_rows(flat, sizes, base, prefix, with_size):  # pragma: no cover - compiled
    out = np.empty(sizes.size * (prefix.size + 22) + 21 * flat.size, dtype=np.uint8)
    digits = np.empty(20, dtype=np.uint8)
    at, k = 0, 0
    for r in range(sizes.size):
        out[at : at + prefix.size] = prefix
        at += prefix.size
        for j in range(-1 if with_size else 0, sizes[r]):
            v = sizes[r] if j < 0 else flat[k + j] + base
            if j > 0 or (j == 0 and with_size):  # the size is followed by a blank even before no values
                out[at] = 32
                at += 1
            if v < 0:
                out[at] = 45
                at += 1
                v = -v
            u, m = np.uint64(v), 0
            while True:  # unsigned: division by ten without Python's floor corrections
                digits[m] = _U48 + u % _U10
                m += 1
                u //= _U10
                if u == _U0:
                    break
            for i in range(m):
                out[at + i] = digits[m - 1 - i]
            at += m
        if with_size and sizes[r] == 0:
            out[at] = 32
            at += 1
        k += sizes[r]
        out[at] = 10
        at += 1
    return out[:at]


def format_index_rows(flat, sizes, *, base=0, prefix="", with_size=False) -> str:
    r"""Rows of integers as text lines: ``prefix``, the row size when ``with_size``, the values plus ``base``.

    The same text as ``prefix + " ".join(str(int(i) + base) for i in row) + "\n"`` for
    every row, made in one compiled pass.

    Parameters
    ----------
    flat : ndarray of int64
        The rows' values, concatenated (values within +-2**62).
    sizes : ndarray of int64
        The length of every row.
    base : int, default=0
        Added to every value (1 for the 1-based OBJ indices).
    prefix : str, default=""
        ASCII text opening every line (``"f "``).
    with_size : bool, default=False
        Write the row length first (OFF and PLY faces).

    Examples
    --------
    >>> import numpy as np
    >>> format_index_rows(np.array([0, 1, 2, 2, 1, 3, 4]), np.array([3, 4]), base=1, prefix="f ")
    'f 1 2 3\nf 3 2 4 5\n'
    >>> format_index_rows(np.array([0, 1, 2]), np.array([3]), with_size=True)
    '3 0 1 2\n'
    """
    text = _format_rows(
        np.ascontiguousarray(flat, dtype=np.int64),
        np.ascontiguousarray(sizes, dtype=np.int64),
        int(base),
        np.frombuffer(prefix.encode("ascii"), dtype=np.uint8),
        bool(with_size),
    )
    return text.tobytes().decode("ascii")


def rows_text(rows, *, base=0, prefix="", with_size=False) -> str:
    r"""Integer rows as text lines, as :func:`format_index_rows` writes them, for any rows the writers take.

    Rows that are not integers (or are beyond +-2**62), and fewer than
    :data:`~.common.FAST_MIN_VALUES` values, are written by the Python loop the compiled
    pass stands for, ``int(i) + base`` every value (so that bad values fail alike).

    Parameters
    ----------
    rows : ndarray of shape (n, k) or sequence of sequences
    base, prefix, with_size
        See :func:`format_index_rows`.

    Examples
    --------
    >>> rows_text([[0, 1, 2], [2, 3, 0, 1]], base=1, prefix="f ")
    'f 1 2 3\nf 3 4 1 2\n'
    """
    try:
        flat, sizes = flat_rows(rows)
    except (TypeError, ValueError):
        flat = sizes = None
    if flat is not None and flat.size >= common.FAST_MIN_VALUES and max(-int(flat.min()), int(flat.max())) < 2**62:
        return format_index_rows(flat, sizes, base=base, prefix=prefix, with_size=with_size)
    return "".join(
        prefix + (f"{len(r)} " if with_size else "") + " ".join(str(int(i) + base) for i in r) + "\n" for r in rows
    )
