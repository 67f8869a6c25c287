"""Blocks of rows spread over a ``distributed`` cluster's workers before they are predicted.

A prediction task's only input is its block of rows, so the scheduler runs it where the
block is held (:mod:`ndboundary.learn.workercopy`). The blocks of a persisted array may be
held unevenly, though: six blocks on one worker and four on the other, or every block on
the worker that loaded them. The scheduler's work stealing does not even that out when
the tasks are long and their blocks large: a worker that runs out of tasks takes one from
a busy worker only if moving its block costs clearly less than the time it would gain,
at the bandwidth the scheduler assumes until it has measured one. Predicting a row costs
far more than sending it to another worker (a neighbour search and its sums against a
copy of the row's bytes), so :func:`balanced_blocks` moves the fewest blocks that even
out the rows per thread, before the prediction is computed.
"""

from __future__ import annotations

import uuid

__all__ = ["balance_plan", "balanced_blocks"]


def balance_plan(rows, holders, threads):
    """Which blocks to move where, so that the rows per thread of the busiest worker fall.

    Parameters
    ----------
    rows : sequence of int
        The rows of each block.
    holders : sequence of sequences
        The workers holding each block (a block held by several runs on any of them).
    threads : dict
        Threads of each worker that may run tasks, the workers holding no block included.

    Returns
    -------
    dict
        Block index -> the worker to move it to. A block moves from the most loaded worker
        (rows per thread) to the worker whose load it raises least, while that keeps it
        below the busiest's; the block moved is the last one of the busiest worker that
        does, since a worker runs its tasks about in order and the move has the longest
        to land.

    Examples
    --------
    >>> balance_plan([100] * 10, [["a"]] * 6 + [["b"]] * 4, {"a": 1, "b": 1})
    {5: 'b'}
    >>> balance_plan([100] * 4, [["a"]] * 4, {"a": 1, "b": 1, "c": 2})
    {3: 'c', 2: 'b', 1: 'c'}
    >>> balance_plan([100] * 10, [["a"]] * 5 + [["b"]] * 5, {"a": 1, "b": 1})
    {}
    """
    threads = {w: t for w, t in threads.items() if t > 0}
    load = dict.fromkeys(threads, 0.0)
    owner = []
    for r, held in zip(rows, holders, strict=True):
        held = [w for w in held if w in threads]
        if not held:  # held by no worker that runs tasks: left where it is
            owner.append(None)
            continue
        w = min(held, key=lambda h: (load[h] + r / threads[h], h))
        load[w] += r / threads[w]
        owner.append(w)
    moves = {}
    for _ in range(len(owner)):
        busy = max(load, key=lambda w: (load[w], w))
        pick = None
        for i in range(len(owner) - 1, -1, -1):
            if owner[i] != busy:
                continue
            after = {w: load[w] + rows[i] / threads[w] for w in load if w != busy}
            idle = min(after, key=lambda w: (after[w], w), default=None)
            if idle is not None and after[idle] < load[busy]:
                pick = i
                break
        if pick is None:
            break
        load[busy] -= rows[pick] / threads[busy]
        load[idle] += rows[pick] / threads[idle]
        owner[pick] = idle
        if idle in holders[pick]:  # back where it is held
            moves.pop(pick, None)
        else:
            moves[pick] = idle
    return moves


def _copy(block):
    return block


def balanced_blocks(client, X):
    """``X`` with its blocks spread evenly over the workers of ``client`` per thread.

    Only for an array whose every block is already in the cluster's memory, one block of
    columns wide (a persisted array): the blocks :func:`balance_plan` moves are copied,
    at once, by a task pinned to their new worker, and ``X`` is returned with those
    copies in their place (held while the returned array is; a copy whose worker has
    left is made on another). Any other array is
    returned as it is: its blocks are made by the tasks that need them, which the
    scheduler spreads over the workers as they run.
    """
    from dask.core import flatten
    from distributed import futures_of

    if client.asynchronous or len(X.chunks[1]) != 1:
        return X
    keys = list(flatten(X.__dask_keys__()))
    futures = {f.key: f for f in futures_of(X)}
    if len(keys) < 2 or set(futures) != set(keys):
        return X
    who_has = client.who_has([futures[k] for k in keys])
    holders = [who_has.get(k, ()) for k in keys]
    moves = balance_plan(X.chunks[0], holders, client.nthreads())
    if not moves:
        return X
    tag = uuid.uuid4().hex
    blocks = dict(futures)
    for i, worker in moves.items():
        blocks[keys[i]] = client.submit(
            _copy,
            futures[keys[i]],
            key=f"ndboundary-moved-{tag}-{i}",
            workers=[worker],
            allow_other_workers=True,
            pure=False,
        )
    rebuild, args = X.__dask_postpersist__()
    return rebuild(blocks, *args)
