"""The engines run tasks and count progress the same way: this process, a pool, Dask."""

from __future__ import annotations

import os
import time

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.engine import (
    InlineEngine,
    LocalPoolEngine,
    ProgressTally,
    TaskReport,
    in_task_order,
    open_engine,
)
from nsrmp_bench.errors import EngineError, InvalidArgument


def square_slowly(x: int, *, report: TaskReport) -> tuple[int, int]:
    """A task: ``x`` units of work, then ``x * x`` and the process it ran in."""
    for _ in range(x):
        time.sleep(0.01)
        report.advance()
    return x * x, os.getpid()


def test_in_task_order_restores_the_order() -> None:
    assert list(in_task_order([(2, "c"), (0, "a"), (3, "d"), (1, "b")])) == list("abcd")


def test_a_rerun_task_is_counted_once() -> None:
    seen: list[int] = []
    tally = ProgressTally(seen.append)
    tally.update(0, 3)
    tally.update(1, 2)
    tally.update(0, 1)  # task 0 restarted on another worker
    tally.finish(0, 4)
    tally.update(0, 2)  # a late message of the dead attempt
    tally.finish(1, 2)
    assert tally.total == 6 and sum(seen) == 6 and -2 in seen


@pytest.mark.parametrize("engine", [InlineEngine(), LocalPoolEngine(2)],
                         ids=["inline", "local-pool"])
def test_engines_run_every_task_and_count_every_unit(engine) -> None:  # type: ignore[no-untyped-def]
    progress: list[int] = []
    with engine:
        results = dict(engine.map_unordered(square_slowly, [(k,) for k in range(6)],
                                            on_progress=progress.append))
    assert {k: r[0] for k, r in results.items()} == {k: k * k for k in range(6)}
    assert sum(progress) == sum(range(6))
    pids = {r[1] for r in results.values()}
    assert (pids == {os.getpid()}) == isinstance(engine, InlineEngine)


def test_open_engine_names_what_is_wrong() -> None:
    assert isinstance(open_engine("local", workers=1), InlineEngine)
    with pytest.raises(InvalidArgument, match=r"unknown engine 'spark'; expected one of local, dask"):
        open_engine("spark")
    with pytest.raises(InvalidArgument, match="needs --engine dask"):
        open_engine("local", scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(InvalidArgument, match="--workers must be >= 1, got 0"):
        open_engine("local", workers=0)


@pytest.mark.dask
def test_dask_runs_tasks_and_reports_progress() -> None:
    pytest.importorskip("distributed")
    progress: list[int] = []
    with open_engine("dask", workers=2) as engine:
        assert "2 worker(s)" in engine.describe()
        results = dict(engine.map_unordered(square_slowly, [(k,) for k in range(6)],
                                            on_progress=progress.append))
    assert {k: r[0] for k, r in results.items()} == {k: k * k for k in range(6)}
    assert sum(progress) == sum(range(6))
    assert os.getpid() not in {r[1] for r in results.values()}


@pytest.mark.dask
def test_an_unreachable_scheduler_is_a_clear_error(capsys: pytest.CaptureFixture[str],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("distributed")
    monkeypatch.setenv("DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT", "1s")
    import dask

    dask.config.refresh()
    try:
        with pytest.raises(EngineError, match=r"cannot reach the Dask scheduler at "
                                              r"'tcp://127.0.0.1:9'.*drop --scheduler"):
            open_engine("dask", scheduler="tcp://127.0.0.1:9").__enter__()
        assert main(["verify", "/nonexistent", "--engine", "dask",
                     "--scheduler", "tcp://127.0.0.1:9"]) == 2
        assert "cannot reach the Dask scheduler" in capsys.readouterr().err
    finally:
        monkeypatch.delenv("DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT")
        dask.config.refresh()


def test_signals_held_arrive_when_the_block_ends() -> None:
    import signal

    from nsrmp_bench.engine.signals import Terminated, signals_held, sigterm_as_interrupt

    before = signal.getsignal(signal.SIGTERM)
    finished = []
    with sigterm_as_interrupt(), pytest.raises(Terminated):
        with signals_held():
            signal.raise_signal(signal.SIGTERM)
            finished.append("start-up")  # not cut short
        finished.append("after")  # never reached: the signal arrives as the block ends
    assert finished == ["start-up"]
    assert signal.getsignal(signal.SIGTERM) == before

    # Python's own Ctrl-C handler, also where the process started with SIGINT ignored (a
    # command started with `&` by a shell without job control).
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt), signals_held():
            signal.raise_signal(signal.SIGINT)
            finished.append("again")
        assert finished == ["start-up", "again"]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, inherited)
