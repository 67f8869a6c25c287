"""Work in blocks of rows on several threads, for passes whose numpy, LAPACK or faiss
calls release the GIL.
"""

from __future__ import annotations

import os
from collections import deque
from concurrent.futures import ThreadPoolExecutor, wait

__all__ = ["Beside", "available_threads", "in_blocks", "shared_pool"]


#: ``OMP_NUM_THREADS`` as this process was started with, read when ndboundary is imported.
_LAUNCH_LIMIT = os.environ.get("OMP_NUM_THREADS", "")


def available_threads():
    """Threads this process should run at once: the cores it may use, or fewer when
    ``OMP_NUM_THREADS`` says so.

    A Dask worker process gets ``OMP_NUM_THREADS=1`` (``distributed.nanny.pre-spawn-environ``),
    so that the workers of one machine share its cores instead of each starting a thread
    per core; the passes here follow the same limit. It is read once, when ndboundary is
    imported, as an OpenMP runtime reads it when loaded: a ``LocalCluster`` of worker
    processes sets it in the environment of the process that starts it, for its workers
    to inherit, and leaves it there, which must not make that process's own work run on
    one thread.

    Examples
    --------
    >>> available_threads() >= 1
    True
    """
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        cores = os.cpu_count() or 1
    limit = _LAUNCH_LIMIT.strip()
    if limit.isdigit() and int(limit) > 0:
        return max(1, min(cores, int(limit)))
    return max(1, cores)


_SHARED = {}

#: Rows below which :func:`in_blocks` does not cut a block further to share it out.
MIN_BLOCK = 256


def shared_pool():
    """One pool of :func:`available_threads` threads for the whole process, started when
    first asked for: for work split a few ways many times over (a product per iteration of a
    solver), where starting threads each time would cost a sizeable part of the work.

    Examples
    --------
    >>> shared_pool() is shared_pool()
    True
    """
    threads = available_threads()
    pool = _SHARED.get(threads)
    if pool is None:
        pool = _SHARED[threads] = ThreadPoolExecutor(threads, thread_name_prefix="ndboundary")
    return pool


def in_blocks(n, size, compute, *, first_alone=True):
    """``(c, compute(c))`` for the blocks ``c`` (slices of ``size`` rows) of ``range(n)``, in order.

    With ``first_alone``, the first block is computed alone, so that what prepares itself
    on its first call (a neighbour index on its first query) does so once; the others on
    several threads, a few blocks ahead of the one yielded, so that at most that many
    results are held. Blocks are cut no larger than needed for every thread to get one,
    nor smaller than :data:`MIN_BLOCK` rows unless ``size`` is.

    BLAS runs one thread per block meanwhile (the OpenBLAS on POSIX threads that numpy
    and scipy ship; an OpenMP build keeps a count per thread): the blocks' small products
    and batched factorisations (LAPACK on a matrix per point) gain nothing from BLAS's
    threads, and those threads, spinning beside the blocks' own, made a pass of batched
    eigendecompositions on two blocks slower than on one.

    Examples
    --------
    >>> [(c.start, c.stop, total) for c, total in in_blocks(10, 4, lambda c: sum(range(c.start, c.stop)))]
    [(0, 4, 6), (4, 8, 22), (8, 10, 17)]
    """
    threads = available_threads()
    if threads > 1 and n > 1:
        size = min(size, max(MIN_BLOCK, -(-n // (threads + first_alone))))
    blocks = [slice(s, min(n, s + size)) for s in range(0, n, size)]
    if not blocks:
        return
    from .solvers.common import blas_threads

    with blas_threads(1 if len(blocks) > 1 else None):
        yield from _blocks_on_threads(blocks, compute, first_alone, threads)


def _blocks_on_threads(blocks, compute, first_alone, threads):
    if threads == 1:  # in order on this thread: a pool of one would only hand the blocks over
        for c in blocks:
            yield c, compute(c)
        return
    rest = blocks
    if first_alone:
        yield blocks[0], compute(blocks[0])
        rest = blocks[1:]
    if not rest:
        return
    workers = min(len(rest), threads)
    with ThreadPoolExecutor(workers) as pool:
        ahead = deque(pool.submit(compute, c) for c in rest[:workers])
        for i, c in enumerate(rest):
            result = ahead.popleft().result()
            if i + workers < len(rest):
                ahead.append(pool.submit(compute, rest[i + workers]))
            yield c, result


class Beside:
    """``compute(*args)`` on a thread of its own, started now, while the caller goes on:
    :meth:`result` waits for it and returns its value or raises its exception. With one
    available thread (:func:`available_threads`), or ``defer`` (a caller that cannot hold
    what both compute at once), it runs when :meth:`result` is called.

    Its own thread rather than :func:`shared_pool`'s: ``compute`` may itself split work
    over the shared pool and wait for it, which a pool worker must not do with every
    other worker waiting too.

    Examples
    --------
    >>> job = Beside(sum, [1, 2, 3])
    >>> job.result()
    6
    >>> Beside(int, "six").result()
    Traceback (most recent call last):
    ...
    ValueError: invalid literal for int() with base 10: 'six'
    """

    def __init__(self, compute, *args, defer=False):
        self._compute, self._args, self._future = compute, args, None
        if not defer and available_threads() > 1:
            pool = ThreadPoolExecutor(1, thread_name_prefix="ndboundary-beside")
            self._future = pool.submit(compute, *args)
            pool.shutdown(wait=False)  # the thread ends with its one task
            self._compute = self._args = None  # held by the task until it has run, no longer

    def result(self):
        """The value of ``compute(*args)``; call it once (what it holds is then let go)."""
        if self._future is None:
            compute, args, self._compute, self._args = self._compute, self._args, None, None
            return compute(*args)
        future, self._future = self._future, None
        return future.result()

    def abandon(self):
        """Wait for the thread, if one runs, and drop its outcome: for a caller that fails
        before it needs the value, so that none of its work goes on after the caller has
        raised (the BLAS limits it sets and lifts included).
        """
        future, self._future, self._compute, self._args = self._future, None, None, None
        if future is not None:
            wait([future])

    def __enter__(self):
        return self

    def __exit__(self, kind, value, traceback):
        """Leaving a ``with`` block by an exception abandons the work (:meth:`abandon`)."""
        if kind is not None:
            self.abandon()
