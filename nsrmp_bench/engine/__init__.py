"""Where a verb's many independent tasks run: here, a local process pool, or a Dask cluster.

``generate`` hands out one task per shard range, ``verify`` one per shard, ``replay`` one
per chunk of instances, ``evaluate`` one per (source, split part) run; each uses
:func:`open_engine` (the CLI's ``--engine``, ``--workers`` and ``--scheduler``, see
``nsrmp_bench/cli/engine_options.py``) and :meth:`Engine.map_unordered`. What a task
writes, and so the bytes, does not depend on the engine.
"""

from __future__ import annotations

from nsrmp_bench.engine.base import Engine, in_task_order, run_task
from nsrmp_bench.engine.inline import InlineEngine
from nsrmp_bench.engine.local_pool import LocalPoolEngine
from nsrmp_bench.engine.progress import ProgressTally, TaskReport
from nsrmp_bench.errors import InvalidArgument

__all__ = [
    "ENGINES",
    "Engine",
    "InlineEngine",
    "LocalPoolEngine",
    "ProgressTally",
    "TaskReport",
    "in_task_order",
    "open_engine",
    "run_task",
]

ENGINES = ("local", "dask")


def open_engine(name: str = "local", *, workers: int = 2,
                scheduler: str | None = None) -> Engine:
    """The engine ``name`` (enter it with ``with``).

    ``local``: ``workers`` spawned processes, or this process when ``workers`` is 1.
    ``dask``: the cluster at ``scheduler``, or a LocalCluster of ``workers`` processes.
    """
    if name not in ENGINES:
        msg = f"unknown engine {name!r}; expected one of {', '.join(ENGINES)}"
        raise InvalidArgument(msg)
    if workers < 1:
        msg = f"--workers must be >= 1, got {workers}"
        raise InvalidArgument(msg)
    if name == "local":
        if scheduler is not None:
            msg = (f"--scheduler {scheduler!r} needs --engine dask; the local engine "
                   "runs on the local machine only")
            raise InvalidArgument(msg)
        return InlineEngine() if workers == 1 else LocalPoolEngine(workers)
    from nsrmp_bench.engine.dask_cluster import DaskEngine

    return DaskEngine(scheduler, workers=workers)
