"""A fitted classifier's lean copy held by every worker process of a ``distributed`` cluster.

Imported only where a ``distributed`` client runs (it imports ``distributed``). The copy
is installed as a worker plugin rather than scattered as data that each prediction task
depends on: a task whose inputs are its block of rows alone is placed where that block
is held, as any block-wise task is. A dependency held by every worker makes every worker
a candidate instead, and the scheduler's greedy choice (the soonest start, counting each
worker's queue) then sends some blocks to run on another worker than their own, each
moved before its task can start.
"""

from __future__ import annotations

from distributed import get_worker
from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["HeldCopy", "held_copy"]


class HeldCopy(WorkerPlugin):
    """Holds ``lean`` in each worker it is set up on, under the plugin's ``name``.

    Registered with ``Client.register_plugin(plugin, name=name)``, the scheduler sets it
    up on every worker, and on every worker that joins later, until it is unregistered.
    """

    def __init__(self, name, lean):
        self.name = name
        self.lean = lean


def held_copy(name):
    """The lean copy that the worker running the calling task holds under ``name``.

    Raises
    ------
    RuntimeError
        If the worker holds none by that name: its plugin was unregistered, which happens
        when neither the classifier's fit nor any prediction built from it is still held.
    """
    plugin = get_worker().plugins.get(name)
    if plugin is None:
        raise RuntimeError(
            f"the cluster's workers no longer hold the classifier's copy {name!r}: the classifier was "
            "refitted or released, and no lazy prediction built from that fit was kept while it computed; "
            "predict again with the fitted classifier"
        )
    return plugin.lean
