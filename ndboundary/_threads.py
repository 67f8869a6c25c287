"""Work in blocks of rows on several threads, for passes whose numpy, LAPACK or faiss
calls release the GIL.
"""

from __future__ import annotations

import os
from collections import deque
from concurrent.futures import ThreadPoolExecutor

__all__ = ["in_blocks"]


def in_blocks(n, size, compute):
    """``(c, compute(c))`` for the blocks ``c`` (slices of ``size`` rows) of ``range(n)``, in order.

    The first block is computed alone, so that what prepares itself on its first call (a
    neighbour index on its first query) does so once; the others on several threads, a
    few blocks ahead of the one yielded, so that at most that many results are held.

    Examples
    --------
    >>> [(c.start, c.stop, total) for c, total in in_blocks(10, 4, lambda c: sum(range(c.start, c.stop)))]
    [(0, 4, 6), (4, 8, 22), (8, 10, 17)]
    """
    blocks = [slice(s, min(n, s + size)) for s in range(0, n, size)]
    if not blocks:
        return
    yield blocks[0], compute(blocks[0])
    rest = blocks[1:]
    if not rest:
        return
    workers = min(len(rest), os.cpu_count() or 1)
    with ThreadPoolExecutor(workers) as pool:
        ahead = deque(pool.submit(compute, c) for c in rest[:workers])
        for i, c in enumerate(rest):
            result = ahead.popleft().result()
            if i + workers < len(rest):
                ahead.append(pool.submit(compute, rest[i + workers]))
            yield c, result
