"""The engine that runs every task in this process, one after the other (``--workers 1``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

from nsrmp_bench.engine.base import Engine, run_task
from nsrmp_bench.engine.progress import ProgressTally, TaskReport

__all__ = ["InlineEngine"]


class _TallySink:
    def __init__(self, tally: ProgressTally) -> None:
        self.tally = tally

    def send(self, key: int, count: int) -> None:
        self.tally.update(key, count)


class InlineEngine(Engine):
    """Tasks run here, in order; no process is started."""

    name = "inline"

    def describe(self) -> str:
        return "this process"

    @property
    def local_processes(self) -> int:
        return 1

    def _run(self, fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]],
             tally: ProgressTally) -> Iterator[tuple[int, tuple[Any, int]]]:
        sink = _TallySink(tally)
        for k, args in enumerate(tasks):
            yield k, run_task(fn, args, TaskReport(k, sink, interval=0.0))
