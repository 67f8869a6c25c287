r"""Compiled (numba) scans of whole text mesh files: OBJ, and the vertex and face rows of OFF and ASCII PLY.

Every scan reads the file's bytes once and returns its numbers in flat arrays, or
:data:`DEFER` as soon as it meets anything outside the common case: a token that is not
a plain decimal number, a value the format refuses, a byte outside ASCII where it could
change how a line splits (``str.split()`` also splits on Unicode spaces). The readers
then read the file again with their line-by-line parsers, which raise the format's
errors with the file's line numbers; the scans never need line numbers.

Lines end at ``\n``, ``\r`` or ``\r\n`` (the universal newlines of the line-by-line
readers); tokens are separated by the ASCII characters ``str.split()`` splits on
(:func:`~.text_numbers.is_blank`). Coordinates come as the bits of doubles (``uint64``);
a token that only Python's ``float`` converts exactly is a NaN holding its offset
(:data:`~.text_numbers.SLOW_NAN`), which :func:`~.text_numbers.fill_slow` converts.

The loops over lines run until the end or until an output array is full; then the
array is enlarged and the loop resumes. Arrays are never replaced inside a loop, where
numba would count references to them at every line.
"""

from __future__ import annotations

import numba
import numpy as np

from .._kernels import kernel
from .text_numbers import NOT_PLAIN, float_token, int_token, is_blank, is_eol, njit_inline

__all__ = ["DEFER", "blank_rest", "float_rows", "index_rows", "scan_obj"]

#: Status of a scan that met something outside the common case.
DEFER = 1
_FULL = 2  # an output array is full: enlarge it and resume


@njit_inline
def _skip_blanks(buf, p):  # pragma: no cover - compiled
    while p < buf.size and is_blank(buf[p]):
        p += 1
    return p


@njit_inline
def _line_end(buf, p):  # pragma: no cover - compiled
    while p < buf.size and not is_eol(buf[p]):
        p += 1
    return p


@njit_inline
def _obj_vertex(buf, p, coords, at):  # pragma: no cover - compiled
    """The first three coordinates of a ``v`` line, as bits into ``coords[at:]``: ``(count, p, ok)``."""
    count = 0
    while count < 3:
        p = _skip_blanks(buf, p)
        if p >= buf.size or is_eol(buf[p]):
            break
        if buf[p] >= 128:
            return count, p, False
        bits, p, status = float_token(buf, p, False)
        if status == NOT_PLAIN:
            return count, p, False
        coords[at + count] = bits
        count += 1
    return count, p, True


@njit_inline
def _obj_indices(buf, p, flat, at, nv):  # pragma: no cover - compiled
    """The 0-based vertex indices of an ``f`` or ``l`` line into ``flat[at:]``: ``(count, largest, p, status)``.

    ``status`` is 0, :data:`DEFER`, or ``_FULL`` when ``flat`` has no room for them.
    """
    count, largest = 0, -1
    n = buf.size
    while True:
        p = _skip_blanks(buf, p)
        if p >= n or is_eol(buf[p]):
            return count, largest, p, 0
        if buf[p] >= 128:
            break
        value, p, ok = int_token(buf, p, True)
        if not ok:
            break
        if p < n and buf[p] == 47:  # ``v/vt/vn``: what follows the first slash is not read
            while p < n and not (is_blank(buf[p]) or is_eol(buf[p]) or buf[p] >= 128):
                p += 1
            if p < n and buf[p] >= 128:
                break
        elif p < n and not (is_blank(buf[p]) or is_eol(buf[p])):
            break
        if value > 0:
            value -= 1
            largest = max(largest, value)
        elif value < 0 and -value <= nv:  # relative: -1 is the last vertex defined so far
            value += nv
        else:
            break
        if at + count >= flat.size:
            return count, largest, p, _FULL
        flat[at + count] = value
        count += 1
    return count, largest, p, DEFER


@kernel("UniTuple(i8, 2)(u1[::1], i8, u8[::1], i8[::1], i8[::1], u1[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _obj_lines(buf, p, coords, flat, sizes, kinds, state):  # pragma: no cover - compiled
    """Scan OBJ lines from ``p`` on: ``(status, p)``; ``state`` holds the counts (see :func:`scan_obj`)."""
    n = buf.size
    nv, width, n_flat, n_rows, largest = state[0], state[1], state[2], state[3], state[4]
    status = 0
    while p < n:
        p = _skip_blanks(buf, p)
        if p >= n:
            break
        if is_eol(buf[p]):
            p += 1
            continue
        if buf[p] >= 128:
            status = DEFER
            break
        start = p
        while p < n and not (is_blank(buf[p]) or is_eol(buf[p]) or buf[p] >= 128):
            p += 1
        key = buf[start] if p - start == 1 else 0
        if key != 118 and key != 102 and key != 108:  # not ``v``, ``f`` or ``l``: not read
            p = _line_end(buf, p)
            continue
        ok = p >= n or buf[p] < 128
        if ok and key == 118:
            if 3 * nv + 3 > coords.size:
                status, p = _FULL, start
                break
            coords[3 * nv + 2] = 0
            count, p, ok = _obj_vertex(buf, p, coords, 3 * nv)
            ok = ok and count >= 2 and (width == 0 or count == width)
            width = count
            nv += 1
        elif ok:
            if n_rows >= sizes.size:
                status, p = _FULL, start
                break
            count, top, p, line = _obj_indices(buf, p, flat, n_flat, nv)
            if line == _FULL:
                status, p, state[5] = _FULL, start, 2 * flat.size
                break
            ok = line == 0 and (key == 108 or count >= 3)
            largest = max(largest, top)
            sizes[n_rows], kinds[n_rows] = count, key
            n_flat += count
            n_rows += 1
        if not ok:
            status = DEFER
            break
        p = _line_end(buf, p)
    state[0], state[1], state[2], state[3], state[4] = nv, width, n_flat, n_rows, largest
    return status, p


def _grown(a, need):
    """``a``, or a copy with room for ``need`` entries (doubling) when it is too short."""
    if need <= a.size:
        return a
    out = np.empty(max(need, 2 * a.size), dtype=a.dtype)
    out[: a.size] = a
    return out


def scan_obj(buf):
    r"""The ``v``, ``f`` and ``l`` lines of an OBJ file.

    Parameters
    ----------
    buf : ndarray of uint8
        The file's bytes, byte-order mark removed.

    Returns
    -------
    status : int
        0, or :data:`DEFER`.
    coords : ndarray of uint64 of shape (3 * n_vertices,)
        The bits of the first three coordinates of every ``v`` line (z = 0 for two):
        ``coords.view(np.float64)`` (see :func:`~.text_numbers.fill_slow`).
    flat, sizes, kinds : ndarray
        The 0-based vertex indices of the ``f`` and ``l`` lines, their counts, and the
        line's key (``ord("f")`` or ``ord("l")``).

    Examples
    --------
    >>> import numpy as np
    >>> status, coords, flat, sizes, kinds = scan_obj(np.frombuffer(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -1\n", np.uint8))
    >>> status, coords.view(np.float64).reshape(-1, 3)[1].tolist(), flat.tolist(), sizes.tolist()
    (0, [1.0, 0.0, 0.0], [0, 1, 2], [3])
    """
    n = buf.size
    coords = np.empty(max(64, n // 32), dtype=np.uint64)
    flat = np.empty(max(64, n // 12), dtype=np.int64)
    sizes = np.empty(max(16, n // 48), dtype=np.int64)
    kinds = np.empty(sizes.size, dtype=np.uint8)
    state = np.array([0, 0, 0, 0, -1, 0], dtype=np.int64)  # vertices, width, indices, index lines, largest, room
    p, status = 0, _FULL
    while status == _FULL:
        status, p = _obj_lines(buf, p, coords, flat, sizes, kinds, state)
        if status == _FULL:
            coords, flat = _grown(coords, 3 * int(state[0]) + 3), _grown(flat, int(state[5]))
            sizes, kinds = _grown(sizes, int(state[3]) + 1), _grown(kinds, int(state[3]) + 1)
    nv, n_flat, n_rows = (int(k) for k in state[[0, 2, 3]])
    if state[4] >= nv:  # an index past the last vertex
        status = DEFER
    return status, coords[: 3 * nv], flat[:n_flat], sizes[:n_rows], kinds[:n_rows]


@njit_inline
def _next_row(buf, p, strict):  # pragma: no cover - compiled
    """The start of the next row with a token (OFF: blank and ``#`` lines skipped), or -1 to defer.

    ``strict`` (ASCII PLY): the row must start at ``p``.
    """
    n = buf.size
    while p < n:
        if strict:
            return p if not (is_blank(buf[p]) or is_eol(buf[p]) or buf[p] >= 128 or buf[p] == 35) else -1
        p = _skip_blanks(buf, p)
        if p >= n:
            break
        c = buf[p]
        if c == 35:
            p = _line_end(buf, p)
        elif is_eol(c):
            p += 1
        elif c >= 128:
            return -1
        else:
            return p
    return -1


@njit_inline
def _row_done(buf, p, strict):  # pragma: no cover - compiled
    """Past the end of a row whose tokens are read, or -1 when (``strict``) more than blanks follow them."""
    if not strict:
        return min(_line_end(buf, p) + 1, buf.size)
    while p < buf.size and (buf[p] == 32 or buf[p] == 9):
        p += 1
    if p >= buf.size:
        return p
    if buf[p] == 10:
        return p + 1
    if buf[p] == 13 and p + 1 < buf.size and buf[p + 1] == 10:
        return p + 2
    return -1


@njit_inline
def _token_start(buf, p, strict):  # pragma: no cover - compiled
    """The start of the row's next token, or -1 when the row ends (or has a byte the scans do not read)."""
    if strict:
        while p < buf.size and (buf[p] == 32 or buf[p] == 9):
            p += 1
    else:
        p = _skip_blanks(buf, p)
    if p >= buf.size or is_eol(buf[p]) or buf[p] >= 128 or (buf[p] == 35 and not strict):
        return -1
    return p


@kernel("UniTuple(i8, 2)(u1[::1], i8, i8, i8, b1, u8[::1])")
@numba.njit(cache=True, nogil=True)
def _float_rows(buf, p, n_rows, n_cols, strict, coords):  # pragma: no cover - compiled
    for i in range(n_rows):
        p = _next_row(buf, p, strict)
        if p < 0:
            return DEFER, p
        for j in range(n_cols):
            p = _token_start(buf, p, strict)
            if p < 0:
                return DEFER, p
            bits, p, status = float_token(buf, p, not strict)
            if status == NOT_PLAIN:
                return DEFER, p
            if j < 3:
                coords[3 * i + j] = bits
        p = _row_done(buf, p, strict)
        if p < 0:
            return DEFER, p
    return 0, p


def float_rows(buf, p, n_rows, n_cols, strict):
    r"""``n_rows`` rows of at least (``strict``: exactly) ``n_cols`` float tokens; the first three are kept.

    Not ``strict`` (OFF): blank and ``#`` lines are skipped, a ``#`` ends a row and what
    follows the ``n_cols`` tokens is not read. ``strict`` (ASCII PLY): no blank or
    comment lines, only spaces and tabs between tokens.

    Returns ``(status, coords, p)``: ``coords`` of shape (3 * n_rows,) holds the bits
    of the values (as :func:`scan_obj`), ``p`` is past the rows.

    Examples
    --------
    >>> import numpy as np
    >>> status, coords, p = float_rows(np.frombuffer(b"OFF\n0 0.5 1 # c\n\n2 3 4 255\n", np.uint8), 4, 2, 3, False)
    >>> status, coords.view(np.float64).tolist(), p
    (0, [0.0, 0.5, 1.0, 2.0, 3.0, 4.0], 27)
    """
    coords = np.empty(3 * n_rows, dtype=np.uint64)
    status, p = _float_rows(buf, p, n_rows, n_cols, strict, coords)
    return status, coords, p


@kernel("UniTuple(i8, 3)(u1[::1], i8, i8, i8, i8, b1, i8, i8[::1], i8[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _index_rows(buf, p, first, n_rows, n_vertices, strict, max_count, flat, sizes, state):  # pragma: no cover
    """Rows ``first..n_rows - 1`` of :func:`index_rows`: ``(status, row reached, p)``; ``state[0]`` counts indices."""
    n_flat = state[0]
    for i in range(first, n_rows):
        row = p
        p = _next_row(buf, p, strict)
        if p < 0:
            return DEFER, i, p
        k, p, ok = int_token(buf, p, not strict)
        if not ok or k < 3 or k > max_count:
            return DEFER, i, p
        if n_flat + k > flat.size:
            state[0] = n_flat
            return _FULL, i, row
        for j in range(k + 1):
            if j > 0:
                value, p, ok = int_token(buf, p, not strict)
                if not ok or value < 0 or value >= n_vertices:
                    return DEFER, i, p
                flat[n_flat + j - 1] = value
            if not (p >= buf.size or is_blank(buf[p]) or is_eol(buf[p]) or (buf[p] == 35 and not strict)):
                return DEFER, i, p
            if j < k:
                p = _token_start(buf, p, strict)
                if p < 0:
                    return DEFER, i, p
        p = _row_done(buf, p, strict)
        if p < 0:
            return DEFER, i, p
        sizes[i] = k
        n_flat += k
    state[0] = n_flat
    return 0, n_rows, p


def index_rows(buf, p, n_rows, n_vertices, strict, max_count):
    r"""``n_rows`` face rows ``k i_1 ... i_k``, ``3 <= k <= max_count``, every ``i`` in ``0..n_vertices - 1``.

    ``strict`` as in :func:`float_rows` (and no signs); otherwise what follows the
    ``k + 1`` tokens is not read (OFF colours). Returns ``(status, flat, sizes, p)``.

    Examples
    --------
    >>> import numpy as np
    >>> status, flat, sizes, p = index_rows(np.frombuffer(b"3 0 1 2\n4 0 1 2 3 255 0 0\n", np.uint8), 0, 2, 4, False, 9)
    >>> status, flat.tolist(), sizes.tolist()
    (0, [0, 1, 2, 0, 1, 2, 3], [3, 4])
    """
    flat = np.empty(3 * n_rows + 16, dtype=np.int64)
    sizes = np.empty(n_rows, dtype=np.int64)
    state = np.zeros(1, dtype=np.int64)
    row, status = 0, _FULL
    while status == _FULL:
        status, row, p = _index_rows(buf, p, row, n_rows, n_vertices, strict, max_count, flat, sizes, state)
        if status == _FULL:
            flat = _grown(flat, 2 * flat.size)
    return status, flat[: state[0]], sizes, p


@kernel("b1(u1[::1], i8, b1)")
@numba.njit(cache=True, nogil=True)
def blank_rest(buf, p, comments):  # pragma: no cover - compiled
    """Whether nothing but blanks, line ends and (``comments``) ``#`` comments follows ``p``."""
    while p < buf.size:
        c = buf[p]
        if c == 35 and comments:
            p = _line_end(buf, p)
        elif is_blank(c) or is_eol(c):
            p += 1
        else:
            return False
    return True
