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

import heapq
import uuid

__all__ = ["balance_plan", "balanced_blocks"]


def balance_plan(rows, holders, threads):
    """Which blocks to move where, so that each worker runs about its share of the rows.

    Parameters
    ----------
    rows : sequence of int
        The rows of each block.
    holders : sequence of sequences
        The workers holding each block (a block held by several runs on any of them, and
        counts here with the one of them it loads least).
    threads : dict
        Threads of each worker that may run tasks, the workers holding no block included.

    Returns
    -------
    dict
        Block index -> the worker to move it to. A worker's share is the rows in
        proportion to its threads. A worker above its share by more than half its last
        block gives that block away (the last, since a worker runs its tasks about in
        order and the move then has the longest to land) to the worker below its share
        that it loads least per thread, as long as that worker's rows per thread stay
        below the giver's and it ends above its share by at most half the block.

    Examples
    --------
    >>> balance_plan([100] * 10, [["a"]] * 6 + [["b"]] * 4, {"a": 1, "b": 1})
    {5: 'b'}
    >>> balance_plan([100] * 4, [["a"]] * 4, {"a": 1, "b": 1, "c": 2})
    {3: 'c', 2: 'b', 1: 'c'}
    >>> balance_plan([100] * 9, [["a"]] * 5 + [["b"]] * 4, {"a": 1, "b": 1})
    {}
    """
    threads = {w: t for w, t in threads.items() if t > 0}
    placed = dict.fromkeys(threads, 0)
    runs = {w: [] for w in threads}  # the blocks each worker runs, in order
    for i, (r, held) in enumerate(zip(rows, holders, strict=True)):
        held = [w for w in held if w in threads]
        if held:  # else held by no worker that runs tasks: left where it is
            w = min(held, key=lambda h: ((placed[h] + r) / threads[h], h))
            placed[w] += r
            runs[w].append(i)
    total, count = sum(placed.values()), sum(map(len, runs.values()))
    if count == 0:
        return {}
    share = {w: total * t / sum(threads.values()) for w, t in threads.items()}
    mean = total / count
    short = [((placed[w] + mean) / threads[w], w) for w in threads if placed[w] < share[w]]
    heapq.heapify(short)
    moves = {}
    for w in sorted(threads, key=lambda w: ((share[w] - placed[w]) / threads[w], w)):
        while runs[w] and short:
            i = runs[w][-1]
            to = short[0][1]
            if placed[to] + rows[i] - share[to] > rows[i] / 2:  # full
                heapq.heappop(short)
                continue
            if placed[w] - share[w] <= rows[i] / 2 or (placed[to] + rows[i]) / threads[to] >= placed[w] / threads[w]:
                break
            runs[w].pop()
            placed[w] -= rows[i]
            placed[to] += rows[i]
            heapq.heapreplace(short, ((placed[to] + mean) / threads[to], to))
            if to not in holders[i]:
                moves[i] = to
    return moves


def _copy(block):
    return block


def balanced_blocks(client, X):
    """``X`` with its blocks spread evenly over the workers of ``client`` per thread.

    Only for an array whose every block is already in the cluster's memory, one block of
    columns wide (a persisted array): the blocks :func:`balance_plan` moves are copied,
    at once, by a task pinned to their new worker, and ``X`` is returned with those
    copies in their place (held while the returned array is; a copy whose worker has
    left is made on another). Any other array is returned as it is: its blocks are made
    by the tasks that need them, which the scheduler spreads over the workers as they
    run.
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
