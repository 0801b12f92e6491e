"""The engine that runs every task in this process, one after the other (``--workers 1``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from nsrmp_bench.engine.base import Engine, ProgressCallback, run_task
from nsrmp_bench.engine.progress import ProgressTally, TaskReport

__all__ = ["InlineEngine"]

R = TypeVar("R")


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

    def map_unordered(
        self,
        fn: Callable[..., R],
        tasks: Sequence[tuple[Any, ...]],
        *,
        on_progress: ProgressCallback | None = None,
    ) -> Iterator[tuple[int, R]]:
        tally = ProgressTally(on_progress)
        sink = _TallySink(tally)
        for k, args in enumerate(tasks):
            result, count = run_task(fn, args, TaskReport(k, sink, interval=0.0))
            tally.finish(k, count)
            yield k, result
