"""Progress of tasks that run elsewhere: counted where a task runs, summed where it was sent.

A task gets a :class:`TaskReport` as its ``report`` argument and calls
:meth:`TaskReport.advance` once per unit of work (an episode generated, rehashed or
replayed). The report sends the task's running count, at most every ``interval`` seconds,
through a :class:`ProgressSink` (a queue to a local pool's driver, an event to a Dask
client). The driver's :class:`ProgressTally` keeps the latest count of every task and turns
them into increments of the total, so a task that is rerun after its worker died counts
its units once, not twice.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol

__all__ = ["ProgressSink", "ProgressTally", "TaskReport"]


class ProgressSink(Protocol):
    """Where a task's running count goes (it must pickle, to travel with the task)."""

    def send(self, key: int, count: int) -> None:
        """Deliver ``count`` units done so far by task ``key``."""


class TaskReport:
    """Counts the units one task has done; sends the count at most every ``interval`` s."""

    def __init__(self, key: int, sink: ProgressSink | None = None,
                 interval: float = 0.25) -> None:
        self.key = key
        self.sink = sink
        self.interval = interval
        self.count = 0
        self._sent_at = -math.inf

    def advance(self, n: int = 1) -> None:
        """``n`` more units done."""
        self.count += n
        now = time.monotonic()
        if self.sink is not None and now - self._sent_at >= self.interval:
            self._sent_at = now
            self.sink.send(self.key, self.count)


class ProgressTally:
    """The driver's view: the latest count per task, reported as increments of the total."""

    def __init__(self, on_progress: Callable[[int], None] | None) -> None:
        self._on_progress = on_progress
        self._counts: dict[int, int] = {}
        self._finished: set[int] = set()

    @property
    def total(self) -> int:
        """Units done over all tasks, as far as the driver knows."""
        return sum(self._counts.values())

    def update(self, key: int, count: int) -> None:
        """Task ``key`` reports ``count`` units so far (a rerun starts again from 0)."""
        if key in self._finished:
            return  # a late message from an attempt that is already accounted for
        delta = count - self._counts.get(key, 0)
        self._counts[key] = count
        if delta and self._on_progress is not None:
            self._on_progress(delta)

    def finish(self, key: int, count: int) -> None:
        """Task ``key`` finished with ``count`` units; later messages about it are stale."""
        self.update(key, count)
        self._finished.add(key)
