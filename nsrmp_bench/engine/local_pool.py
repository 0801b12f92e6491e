"""The engine of one machine: a pool of spawned worker processes (``--engine local``).

Spawned, not forked, so that a worker starts with no PyBullet or h5py state of the driver.
Progress comes back through a manager queue that the driver drains while it waits.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue as queue_module
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing.managers import SyncManager
from typing import Any

from nsrmp_bench.engine.base import Engine, run_task
from nsrmp_bench.engine.progress import ProgressTally, TaskReport
from nsrmp_bench.engine.signals import watch_parent
from nsrmp_bench.errors import InvalidArgument

__all__ = ["LocalPoolEngine"]
_POLL_S = 0.2


class _QueueSink:
    def __init__(self, q: queue_module.Queue[tuple[int, int]]) -> None:
        self.q = q

    def send(self, key: int, count: int) -> None:
        self.q.put((key, count))


def _drain(q: queue_module.Queue[tuple[int, int]], tally: ProgressTally) -> None:
    while True:
        try:
            key, count = q.get_nowait()
        except queue_module.Empty:
            return
        tally.update(key, count)


class LocalPoolEngine(Engine):
    """Up to ``workers`` spawned processes, started per :meth:`map_unordered` call."""

    name = "local"

    def __init__(self, workers: int) -> None:
        if workers < 1:
            msg = f"workers must be >= 1, got {workers}; use 1 to run in this process"
            raise InvalidArgument(msg)
        self.workers = workers

    def describe(self) -> str:
        return f"a local pool of {self.workers} process(es)"

    @property
    def local_processes(self) -> int:
        return self.workers

    def _run(self, fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]],
             tally: ProgressTally) -> Iterator[tuple[int, tuple[Any, int]]]:
        ctx = mp.get_context("spawn")
        manager = SyncManager(ctx=ctx)
        manager.start(watch_parent, (os.getpid(),))  # ends itself if this process dies
        with manager:
            q = manager.Queue()
            sink = _QueueSink(q)
            with ProcessPoolExecutor(max_workers=min(self.workers, len(tasks)),
                                     mp_context=ctx, initializer=watch_parent,
                                     initargs=(os.getpid(),)) as pool:
                futures: dict[Future[tuple[Any, int]], int] = {
                    pool.submit(run_task, fn, args, TaskReport(k, sink)): k
                    for k, args in enumerate(tasks)
                }
                pending = set(futures)
                try:
                    while pending:
                        finished, pending = wait(pending, timeout=_POLL_S,
                                                 return_when=FIRST_COMPLETED)
                        _drain(q, tally)
                        for fut in finished:
                            yield futures[fut], fut.result()
                except BaseException:
                    _stop_workers(pool)  # Ctrl-C, SIGTERM, a task's error: stop at once
                    raise
                finally:
                    for fut in pending:
                        fut.cancel()


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the workers now, not after their tasks.

    The pool has no public handle on its processes; ``_processes`` (pid -> process) has
    been there since Python 3.2.
    """
    procs = list((pool._processes or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=5)
        if proc.is_alive():
            proc.kill()
            proc.join()
