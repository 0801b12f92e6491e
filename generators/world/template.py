"""Instances forked from a template world: the per-instance reset without reloading.

Every instance starts from a freshly reset world (:meth:`World.begin`), and most of that
reset is reloading the table and the Panda (Bullet parses their meshes and computes a
convex hull per link). Here the process builds that scenery once (:meth:`World.prime`)
and never touches it again; each instance runs in a child forked from it, whose Bullet
state is, byte for byte, the one ``begin`` would have built before adding the objects
(fork copies the memory), so ``begin`` only adds the objects. The child sends its result
back through a pipe and exits; the template stays pristine for the next instance.

Measured, it is slower than the in-process reset (0.58x the episodes per second, CPU):
fork, the copy-on-write faults and the child's exit cost more than the reload saves
(``docs/performance.md``). ``generate`` does not use it; ``benchmarks/bench_generate.py
--forked`` does.

The bytes are those of the in-process path (``tests/world/test_template.py``): an instance
depends on nothing but the state its ``begin`` starts from, whatever ran in the process
before (``tests/world/test_determinism.py``).

A child that is interrupted (Ctrl-C reaches the whole process group; SIGTERM) dies with
the default action; when the parent is interrupted while it waits, it kills and reaps the
child before the interrupt goes on. A child whose parent died ends when it writes its
result to the closed pipe.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import sys
import traceback
import warnings
from collections.abc import Callable
from typing import TypeVar

from nsrmp_bench.generators.world.world import World

__all__ = ["can_fork", "run_forked"]

T = TypeVar("T")


def can_fork() -> bool:
    """Whether this platform has ``os.fork`` (POSIX)."""
    return hasattr(os, "fork")


def _child(write_fd: int, fn: Callable[[], object]) -> None:
    """The forked child: run ``fn``, pickle ``(ok, value)`` into the pipe, exit."""
    code = 0
    try:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        try:
            payload = pickle.dumps((True, fn()), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:
            try:
                payload = pickle.dumps((False, exc), protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:
                text = "".join(traceback.format_exception(exc))
                payload = pickle.dumps((False, RuntimeError(text)),
                                       protocol=pickle.HIGHEST_PROTOCOL)
        with os.fdopen(write_fd, "wb") as pipe:
            pipe.write(payload)
    except BaseException:
        code = 1
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def run_forked(world: World, fn: Callable[[], T]) -> T:
    """``fn()`` run in a child forked from this process, with ``world`` primed.

    ``world`` is primed (:meth:`World.prime`) here the first time; the child's first
    ``world.begin`` then adds only the objects. ``fn``'s result (or exception) is pickled
    back. The parent's world is not touched by the child.
    """
    if not world.primed:
        if not world.has_background():  # cache the empty scene here, not in a child
            world.begin(())
            world.prepare_background()
        world.prime()
    read_fd, write_fd = os.pipe()
    with warnings.catch_warnings():
        # fork in a process with threads (the shard writer's) is safe here: the child
        # runs only PyBullet, numpy and pickle, and leaves by os._exit
        warnings.simplefilter("ignore", DeprecationWarning)
        pid = os.fork()
    if pid == 0:  # pragma: no cover - the child (measured through its result)
        os.close(read_fd)
        _child(write_fd, fn)
    os.close(write_fd)
    status = None
    try:
        with os.fdopen(read_fd, "rb") as pipe:
            data = pipe.read()
        _, status = os.waitpid(pid, 0)
    finally:
        if status is None:  # interrupted while waiting: end the child, then go on
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
    if not data:
        msg = (f"the forked generator child ended without a result ("
               f"{_describe(status)}); run again (complete shards are kept)")
        raise RuntimeError(msg)
    ok, value = pickle.loads(data)
    if not ok:
        raise value
    result: T = value
    return result


def _describe(status: int) -> str:
    if os.WIFSIGNALED(status):
        return f"killed by {signal.Signals(os.WTERMSIG(status)).name}"
    return f"exit status {os.waitstatus_to_exitcode(status)}"
