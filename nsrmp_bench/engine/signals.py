"""Stopping a run cleanly: SIGTERM handled like Ctrl-C, and workers that outlive their driver.

``timeout``, ``kill`` and batch schedulers stop a command with SIGTERM, which by default
ends the driver without a word and leaves its pool workers running. Inside
:func:`sigterm_as_interrupt` a SIGTERM raises :class:`Terminated` (a ``KeyboardInterrupt``),
so the same clean-up as Ctrl-C runs: engines stop their workers, writers remove their
``*.tmp``, and the command exits 143. A worker started with :func:`watch_parent` as its
initializer ends itself when its driver is gone (SIGKILL, a crash), instead of going on
writing under PID 1. Within :func:`signals_held` Ctrl-C and SIGTERM wait until a start-up
that cannot be cut short cleanly is done, and then stop it whole.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["EXIT_SIGTERM", "Terminated", "signals_held", "sigterm_as_interrupt",
           "watch_parent"]

EXIT_SIGTERM = 128 + signal.SIGTERM
"""The exit status of a command stopped by SIGTERM (143), as a shell reports it."""

_PARENT_POLL_S = 0.5


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (raised where it was, like Ctrl-C's KeyboardInterrupt)."""


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    # Raise once: the clean-up it starts should not be cut short by a second SIGTERM.
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise Terminated(signal.Signals(signum).name)


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated`; the old handler is restored.

    Only the main thread may set signal handlers; elsewhere the block changes nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


_HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def signals_held() -> Iterator[None]:
    """Within the block, Ctrl-C (SIGINT) and SIGTERM wait; once it ends they are delivered
    to the handlers of before (so :class:`Terminated` or ``KeyboardInterrupt`` is raised
    where the block ends, not inside it).

    For a start-up that an interruption would leave half-done, with nothing to close it by
    (a Dask LocalCluster's nannies): it takes a second or two, then the usual clean-up
    stops all of it. Only the main thread may set signal handlers; elsewhere the block
    changes nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        if signum not in received:
            received.append(signum)

    # a handler set outside Python (None) cannot be put back: that signal is left alone
    previous = {signum: handler for signum in _HELD
                if (handler := signal.getsignal(signum)) is not None}
    for held in previous:
        signal.signal(held, hold)
    try:
        yield
    finally:
        for held, handler in previous.items():
            signal.signal(held, handler)
        for signum in received:  # the first handler that raises ends the loop
            signal.raise_signal(signum)


def _watch(parent_pid: int) -> None:
    while True:
        time.sleep(_PARENT_POLL_S)
        if os.getppid() != parent_pid:  # reparented: the driver is gone
            os._exit(EXIT_SIGTERM)


def watch_parent(parent_pid: int) -> None:
    """Worker initializer: end this process when ``parent_pid`` is no longer its parent.

    A daemon thread polls the parent id; the worker exits at once (no clean-up: its
    unfinished ``*.tmp`` files are removed when the run is resumed).
    """
    threading.Thread(target=_watch, args=(parent_pid,), name="watch-parent",
                     daemon=True).start()
