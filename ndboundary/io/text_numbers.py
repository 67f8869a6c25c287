"""Compiled (numba) number tokens of text mesh files: decimal floats and integers.

The text readers (:mod:`.obj`, :mod:`.off`, :mod:`.ply`) scan whole files with these
instead of splitting lines in Python (:mod:`.text_scan`). A float token is converted
with the Eisel-Lemire algorithm (Nigel Tao, "The Eisel-Lemire ParseNumberF64 Algorithm",
2020, as in Go's ``strconv``), which gives the correctly rounded double, as Python's
``float`` does, or says that it cannot decide; those tokens, and the ones with more than
19 significant digits or an exponent beyond the range of doubles, are left to ``float``
(:data:`NEEDS_FLOAT`). Only the plain decimal forms are read here (``-1.5e-3``, ``.5``,
``7.``); other spellings Python accepts (``inf``, ``nan``, ``1_000``) are refused
(:data:`NOT_PLAIN`), so that the caller falls back to its line-by-line reader.

The kernels are compiled once and cached on disk (``cache=True``); numba's cache does
not notice edits to this module in the kernels of :mod:`.text_scan` and
:mod:`.text_format` that inline it, so after editing it delete the ``*.nbi`` and
``*.nbc`` files of ``ndboundary/io/__pycache__``.
"""

from __future__ import annotations

import re

import numba
import numpy as np
from llvmlite import ir
from numba.extending import intrinsic

__all__ = [
    "NEEDS_FLOAT",
    "NOT_PLAIN",
    "POW10_MIN_EXP",
    "SLOW_NAN",
    "fill_slow",
    "float_token",
    "int_token",
    "is_blank",
    "is_eol",
    "mul64",
    "njit_inline",
    "pow10_table",
]

#: Status of a float token that is plain decimal but must be converted by Python's ``float``.
NEEDS_FLOAT = 1
#: Status of a token that is not a plain decimal number.
NOT_PLAIN = 2
#: The power of ten of the first row of :func:`pow10_table`.
POW10_MIN_EXP = -348
_POW10_MAX_EXP = 347


def pow10_table():
    """The 128-bit mantissas of ``10**e``, ``e = -348..347``, rounded down, as (high, low) uint64 rows.

    Examples
    --------
    >>> [hex(int(w)) for w in pow10_table()[0]]  # 1e-348, as in Go's strconv
    ['0xfa8fd5a0081c0288', '0x1732c869cd60e453']
    """
    table = np.empty((_POW10_MAX_EXP - POW10_MIN_EXP + 1, 2), dtype=np.uint64)
    for i, e in enumerate(range(POW10_MIN_EXP, _POW10_MAX_EXP + 1)):
        if e >= 0:
            v = 10**e
            b = v.bit_length()
            m = v >> (b - 128) if b > 128 else v << (128 - b)
        else:
            d = 10**-e
            m = (1 << (d.bit_length() + 127)) // d
        table[i, 0], table[i, 1] = m >> 64, m & (2**64 - 1)
    return table


_POW10 = pow10_table()
# numba types mixed signed and unsigned arithmetic as float: every constant is a uint64
_U0, _U1, _U3, _U9, _U10, _U32, _U63 = (np.uint64(k) for k in (0, 1, 3, 9, 10, 32, 63))
_LOW32 = np.uint64(0xFFFFFFFF)
_LOW9 = np.uint64(0x1FF)
_ALL64 = np.uint64(0xFFFFFFFFFFFFFFFF)
_MANTISSA = np.uint64(0x000FFFFFFFFFFFFF)
_SIGN = np.uint64(1 << 63)
#: The bits a float token left to Python's ``float`` gets, or-ed with its start offset: a NaN (parsed
#: tokens are never NaN, ``nan`` is not plain decimal), its low 48 bits the offset.
SLOW_NAN = np.uint64(0x7FFC000000000000)
_EXACT_POW10 = np.array([10.0**k for k in range(23)])  # the powers of ten doubles hold exactly
_U53 = np.uint64(2**53)
_PLAIN_TOKEN = re.compile(rb"[0-9eE.+-]+")
#: Small helpers the scans call for every byte or token are inlined into them (numba's own
#: inlining, which also spares the reference counting of the arrays they are passed).
njit_inline = numba.njit(cache=True, nogil=True, inline="always")


@njit_inline
def is_blank(c):  # pragma: no cover - compiled
    """Whether byte ``c`` separates tokens within a line, as ``str.split()`` does (ASCII only)."""
    return c == 32 or c == 9 or c == 11 or c == 12 or (28 <= c <= 31)


@njit_inline
def is_eol(c):  # pragma: no cover - compiled
    r"""Whether byte ``c`` ends a line (universal newlines: ``\n``, ``\r`` and ``\r\n``)."""
    return c == 10 or c == 13


@intrinsic
def _float_bits(typingctx, x):
    """The IEEE bits of a double, as a uint64."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return numba.types.uint64(numba.types.float64), codegen


@numba.njit(cache=True, nogil=True)
def mul64(a, b):  # pragma: no cover - compiled
    """The high and low words of the 128-bit product of two uint64."""
    a_lo, a_hi = a & _LOW32, a >> _U32
    b_lo, b_hi = b & _LOW32, b >> _U32
    p0, p1, p2 = a_lo * b_lo, a_lo * b_hi, a_hi * b_lo
    mid = (p0 >> _U32) + (p1 & _LOW32) + (p2 & _LOW32)
    return a_hi * b_hi + (p1 >> _U32) + (p2 >> _U32) + (mid >> _U32), (p0 & _LOW32) | (mid << _U32)


@numba.njit(cache=True, nogil=True)
def _leading_zeros(x):  # pragma: no cover - compiled
    n = 0
    for shift in (32, 16, 8, 4, 2, 1):
        if x >> np.uint64(64 - shift) == _U0:
            n += shift
            x = x << np.uint64(shift)
    return n


@numba.njit(cache=True, nogil=True)
def _eisel_lemire(man, exp10):  # pragma: no cover - compiled
    """The bits of ``man * 10**exp10`` (``man > 0``) correctly rounded, or 0 when the algorithm cannot decide."""
    clz = _leading_zeros(man)
    man = man << np.uint64(clz)
    exp2 = ((217706 * exp10) >> 16) + 64 + 1023 - clz
    hi, lo = _POW10[exp10 - POW10_MIN_EXP, 0], _POW10[exp10 - POW10_MIN_EXP, 1]
    x_hi, x_lo = mul64(man, hi)
    if x_hi & _LOW9 == _LOW9 and x_lo + man < man:  # the truncated power may matter: use its low word
        y_hi, y_lo = mul64(man, lo)
        merged_hi, merged_lo = x_hi, x_lo + y_hi
        if merged_lo < x_lo:
            merged_hi += _U1
        if merged_hi & _LOW9 == _LOW9 and merged_lo == _ALL64 and y_lo + man < man:
            return _U0
        x_hi, x_lo = merged_hi, merged_lo
    msb = x_hi >> _U63
    mantissa = x_hi >> (_U9 + msb)
    if msb == _U0:
        exp2 -= 1
    if x_lo == _U0 and x_hi & _LOW9 == _U0 and mantissa & _U3 == _U1:  # halfway: cannot tell
        return _U0
    mantissa = (mantissa + (mantissa & _U1)) >> _U1
    if mantissa >> np.uint64(53) > _U0:
        mantissa = mantissa >> _U1
        exp2 += 1
    if exp2 <= 0 or exp2 >= 0x7FF:  # subnormal or overflow
        return _U0
    return (np.uint64(exp2) << np.uint64(52)) | (mantissa & _MANTISSA)


@njit_inline
def _ends_token(buf, p, hash_ends):  # pragma: no cover - compiled
    if p >= buf.size:
        return True
    c = buf[p]
    return is_blank(c) or is_eol(c) or (hash_ends and c == 35)


@njit_inline
def float_token(buf, p, hash_ends):  # pragma: no cover - compiled
    """The float token at ``buf[p]``: ``(bits, end, status)``.

    ``status`` is 0 (``bits`` are those of the correctly rounded double),
    :data:`NEEDS_FLOAT` (``bits`` are :data:`SLOW_NAN` or-ed with ``p``) or
    :data:`NOT_PLAIN`. The token must end at a blank, a line end, the end of the buffer
    or, when ``hash_ends``, a ``#``.
    """
    n = buf.size
    token = p
    sign = _U0
    if buf[p] == 45 or buf[p] == 43:
        sign = _SIGN if buf[p] == 45 else _U0
        p += 1
    start = p
    while p < n and buf[p] == 48:  # leading zeros
        p += 1
    man, n_sig, exp10 = _U0, 0, 0
    while p < n and 48 <= buf[p] <= 57:
        man = man * _U10 + np.uint64(buf[p] - 48)
        n_sig += 1
        p += 1
    n_digits = p - start
    if p < n and buf[p] == 46:
        p += 1
        frac = p
        if man == _U0:
            while p < n and buf[p] == 48:
                p += 1
            n_digits += p - frac
            exp10 -= p - frac
        digits = p
        while p < n and 48 <= buf[p] <= 57:
            man = man * _U10 + np.uint64(buf[p] - 48)
            p += 1
        n_sig += p - digits
        n_digits += p - digits
        exp10 -= p - digits
    if n_digits == 0:
        return _U0, p, 2
    if p < n and (buf[p] == 101 or buf[p] == 69):
        p += 1
        negative = p < n and buf[p] == 45
        if p < n and (buf[p] == 45 or buf[p] == 43):
            p += 1
        e, first = 0, p
        while p < n and 48 <= buf[p] <= 57:
            if e < 100000:
                e = 10 * e + (buf[p] - 48)
            p += 1
        if p == first:
            return _U0, p, 2
        exp10 += -e if negative else e
    if not _ends_token(buf, p, hash_ends):
        return _U0, p, 2
    if n_sig == 0:
        return sign, p, 0
    if n_sig > 19 or exp10 < POW10_MIN_EXP or exp10 > _POW10_MAX_EXP:  # ``man`` overflowed, or out of range
        return SLOW_NAN | np.uint64(token), p, 1
    if man <= _U53 and -22 <= exp10 <= 22:  # exact operands, one rounding (Clinger): also the exact decimals
        value = float(man) * _EXACT_POW10[exp10] if exp10 >= 0 else float(man) / _EXACT_POW10[-exp10]
        return _float_bits(value) | sign, p, 0
    bits = _eisel_lemire(man, exp10)
    if bits == _U0:
        return SLOW_NAN | np.uint64(token), p, 1
    return bits | sign, p, 0


@njit_inline
def int_token(buf, p, signed):  # pragma: no cover - compiled
    """The integer ``[+-]?[0-9]{1,18}`` at ``buf[p]`` (no sign unless ``signed``): ``(value, end, ok)``.

    The caller checks what follows it.
    """
    n = buf.size
    neg = buf[p] == 45
    if signed and (buf[p] == 45 or buf[p] == 43):
        p += 1
    value, n_digits = 0, 0
    while p < n and 48 <= buf[p] <= 57:
        value = 10 * value + (buf[p] - 48)
        n_digits += 1
        p += 1
    if n_digits == 0 or n_digits > 18:
        return 0, p, False
    return -value if neg else value, p, True


def fill_slow(coords, data):
    """The values of a scan's coordinate bits: the tokens left to Python's ``float`` converted.

    Parameters
    ----------
    coords : ndarray of uint64
        As a scan returns them; those that are NaN hold the offset of their token.
    data : bytes
        The bytes scanned.

    Returns
    -------
    ndarray of float64
        A view of ``coords``.

    Examples
    --------
    >>> import numpy as np
    >>> fill_slow(np.array([0, SLOW_NAN | np.uint64(2)], dtype=np.uint64), b"1 0.125 x").tolist()
    [0.0, 0.125]
    """
    values = coords.view(np.float64)
    for slot in np.flatnonzero(np.isnan(values)).tolist():
        start = int(coords[slot] & np.uint64(2**48 - 1))
        values[slot] = float(_PLAIN_TOKEN.match(data, start).group())
    return values
