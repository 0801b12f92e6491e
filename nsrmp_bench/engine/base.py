"""The engine contract: run many independent tasks somewhere, hear of each as it finishes.

A task is a module-level function called as ``fn(*args, report=report)`` (``report`` is a
:class:`~nsrmp_bench.engine.progress.TaskReport`); it and its arguments must pickle, and
whatever it writes to disk it writes atomically (the shard writer's ``*.tmp`` + rename), so
that an engine may run a task again after its worker died. Engines differ only in where
tasks run: :class:`~nsrmp_bench.engine.inline.InlineEngine` (this process),
:class:`~nsrmp_bench.engine.local_pool.LocalPoolEngine` (spawned processes on this
machine), :class:`~nsrmp_bench.engine.dask_cluster.DaskEngine` (a Dask cluster).
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, TypeVar

from nsrmp_bench.engine.progress import ProgressTally, TaskReport

__all__ = ["Engine", "in_task_order", "run_task"]

R = TypeVar("R")
ProgressCallback = Callable[[int], None]


def run_task(fn: Callable[..., R], args: tuple[Any, ...], report: TaskReport) -> tuple[R, int]:
    """What a worker runs for one task: ``fn(*args, report=report)`` and the count it reached."""
    result = fn(*args, report=report)
    return result, report.count


class Engine(abc.ABC):
    """Runs tasks; a context manager (entering starts a pool or connects to a cluster)."""

    name: str = ""

    @abc.abstractmethod
    def describe(self) -> str:
        """Where tasks run, in words (for progress lines and errors)."""

    @property
    def local_processes(self) -> int | None:
        """How many processes of the local machine run tasks at once (None: not known here,
        e.g. a cluster's workers), so that a task can tell whether cores are left over."""
        return None

    def map_unordered(
        self,
        fn: Callable[..., R],
        tasks: Sequence[tuple[Any, ...]],
        *,
        on_progress: ProgressCallback | None = None,
    ) -> Iterator[tuple[int, R]]:
        """Run ``fn(*tasks[k], report=...)`` for every ``k``; yield ``(k, result)`` as each
        finishes. ``on_progress(n)`` hears of ``n`` more units done (``n`` is negative when a
        task restarts after its worker died). A task's exception is raised here."""
        if not tasks:
            return
        tally = ProgressTally(on_progress)
        for k, (result, count) in self._run(fn, tasks, tally):
            tally.finish(k, count)
            yield k, result

    @abc.abstractmethod
    def _run(self, fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]],
             tally: ProgressTally) -> Iterator[tuple[int, tuple[Any, int]]]:
        """Run :func:`run_task` for every task; yield ``(k, its return)`` as each finishes,
        passing running counts to ``tally.update`` meanwhile."""

    def require_shared_dir(self, path: Path) -> None:  # noqa: B027 (a default, not abstract)
        """Raise unless every worker sees ``path`` (a directory tasks read or write).

        Workers on the local machine always do; a cluster engine checks.
        """

    def close(self) -> None:  # noqa: B027 (a default, not abstract)
        """Release the pool or the cluster connection."""

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def in_task_order(results: Iterable[tuple[int, R]]) -> Iterator[R]:
    """Yield the results of ``(k, result)`` pairs in the order of ``k`` (0, 1, 2 ...)."""
    waiting: dict[int, R] = {}
    nxt = 0
    for k, result in results:
        waiting[k] = result
        while nxt in waiting:
            yield waiting.pop(nxt)
            nxt += 1
