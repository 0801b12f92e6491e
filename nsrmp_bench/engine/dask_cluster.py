"""The engine of many machines: Dask's distributed scheduler (``--engine dask``).

Without a scheduler address :class:`DaskEngine` starts a ``LocalCluster`` on 127.0.0.1 (one
single-threaded worker process per ``workers``); with one it connects to a running
``dask scheduler`` whose ``dask worker`` processes share the data directory's filesystem.
On entering it checks that there are workers, that each runs one thread (tasks are
CPU-bound Python holding one PyBullet world per process) and the same package versions as
this process (other versions could write other bytes). Dask's nanny sets
``MALLOC_TRIM_THRESHOLD_=65536`` in every worker by default; an explicit trim threshold turns
off glibc's adaptive mmap threshold, so every image-sized array is mmap'd and unmapped
again (measured: system time 0.3 s -> 3 s and 40% fewer episodes per second in one
process). The LocalCluster starts without it, and a warning names workers that have it.

Faults: when a worker dies, Dask runs its tasks again on another worker; tasks write
atomically, so a half-written shard is never taken as complete. A task whose workers keep
dying, a scheduler that cannot be reached and one that goes away mid-run end in an
:class:`~nsrmp_bench.errors.EngineError` saying what to do; whatever finished stays on
disk, and rerunning the same command resumes from it. Ctrl-C and SIGTERM (see
:mod:`nsrmp_bench.engine.signals`) close the LocalCluster, its nannies and workers, even in
the middle of its start, without the workers' complaints at being stopped mid-task; its
workers leave a terminal's Ctrl-C to this process, and end when this process is killed
(Dask watches their parent).
"""

from __future__ import annotations

import contextlib
import importlib.metadata
import logging
import os
import platform
import queue as queue_module
import signal
import time
import uuid
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import CancelledError
from pathlib import Path
from types import ModuleType, TracebackType
from typing import TYPE_CHECKING, Any

from nsrmp_bench._optional import require
from nsrmp_bench._version import __version__
from nsrmp_bench.engine.base import Engine, run_task
from nsrmp_bench.engine.progress import ProgressTally, TaskReport
from nsrmp_bench.engine.signals import signals_held
from nsrmp_bench.errors import EngineError, InvalidArgument

if TYPE_CHECKING:
    from distributed import Future

__all__ = ["DaskEngine", "software"]
_POLL_S = 0.2
_TRIM_ENV = "MALLOC_TRIM_THRESHOLD_"
_TRIM_KEY = f"distributed.nanny.pre-spawn-environ.{_TRIM_ENV}"
_PROGRESS_S = 1.0  # a worker's progress events at most once a second: 1,600 workers, 1,600/s
_RERUN = "rerun the same command to resume from the work already written"


def software() -> dict[str, str]:
    """The versions that decide the bytes a task writes (run on every worker to compare)."""
    out = {"python": platform.python_version(), "nsrmp-bench": __version__}
    for dist in ("numpy", "h5py", "pybullet"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out


def _leave_ctrl_c_to_the_driver() -> None:
    """Run on a LocalCluster's worker (in its event loop, the process's main thread): a
    terminal's Ctrl-C reaches every process of the command, and workers that take it close
    themselves in disorder, with tracebacks; the command's process stops them instead."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _hush() -> None:
    """Run on a LocalCluster's worker that the command is about to stop (Ctrl-C, SIGTERM):
    a worker closed in the middle of a task logs the cancellation and its lost heartbeat,
    with tracebacks, which read like a crash; the command says what happened instead."""
    logging.disable(logging.CRITICAL)


class _EventSink:
    """Sends a task's count to the client as a Dask event (batched by the worker)."""

    def __init__(self, topic: str) -> None:
        self.topic = topic

    def send(self, key: int, count: int) -> None:
        from distributed import get_worker

        try:
            worker = get_worker()
        except ValueError:  # not on a Dask worker: nobody to tell
            return
        worker.log_event(self.topic, (key, count))


class DaskEngine(Engine):
    """Tasks run on a Dask cluster: ``scheduler`` (``tcp://HOST:8786``) or a LocalCluster."""

    name = "dask"

    def __init__(
        self,
        scheduler: str | None = None,
        *,
        workers: int = 2,
        connect_timeout_s: float | None = None,
        lost_grace_s: float = 10.0,
        workers_timeout_s: float = 60.0,
    ) -> None:
        if scheduler is None and workers < 1:
            msg = f"workers must be >= 1 for a LocalCluster, got {workers}"
            raise InvalidArgument(msg)
        self._dd: ModuleType = require("distributed")  # untyped calls: keep them Any
        self.scheduler = scheduler
        self.workers = workers
        self._dask: ModuleType = require("dask")
        if connect_timeout_s is None:  # Dask's own knob (DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT)
            connect_timeout_s = float(self._dask.utils.parse_timedelta(
                self._dask.config.get("distributed.comm.timeouts.connect"), default="seconds"))
        self.connect_timeout_s = connect_timeout_s
        self.lost_grace_s = lost_grace_s
        self.workers_timeout_s = workers_timeout_s
        self._cluster: Any = None  # LocalCluster: its close() is untyped
        self._client: Any = None  # Client: its close() is untyped
        self._address = scheduler or "a LocalCluster"
        self._stopping = False  # interrupted: the LocalCluster is stopped without its logs

    # -- connection ----------------------------------------------------------------
    def __enter__(self) -> DaskEngine:
        try:
            if self.scheduler is None:
                # Ctrl-C or SIGTERM in the middle of a LocalCluster's start leaves nannies
                # nothing can close (Dask's exit hook fails on them with a traceback): the
                # signal waits the second or two the start takes, then close() stops it all
                with signals_held():
                    with self._dask.config.set({_TRIM_KEY: None}):  # read at the nannies' start
                        self._cluster = self._dd.LocalCluster(
                            n_workers=self.workers, threads_per_worker=1, processes=True,
                            host="127.0.0.1", dashboard_address=None,
                        )
                    self._address = str(self._cluster.scheduler_address)
                    self._connect()
                    self.client.run(_leave_ctrl_c_to_the_driver)
            else:
                self._connect()
            self._check_workers()
        except BaseException as exc:
            self._release(exc)
            raise
        return self

    def _connect(self) -> None:
        try:
            self._client = self._dd.Client(self._address, timeout=self.connect_timeout_s,
                                           set_as_default=False)
        except (OSError, TimeoutError) as exc:
            msg = (
                f"cannot reach the Dask scheduler at {self._address!r} within "
                f"{self.connect_timeout_s:.0f} s ({exc}); expected a running `dask scheduler` "
                "at that address: start it (and `dask worker ADDRESS --nthreads 1` on each "
                "machine), check the address, or drop --scheduler to start a LocalCluster"
            )
            raise EngineError(msg) from exc

    def close(self) -> None:
        if self._client is not None:
            # a scheduler that is gone already leaves nothing to release
            with contextlib.suppress(OSError, TimeoutError, RuntimeError):
                self._client.close(timeout=5)
            self._client = None
        if self._cluster is not None:
            # stopped on purpose: the nannies' and the scheduler's complaints about busy
            # workers (killed after a few seconds) are not news
            disabled = logging.root.manager.disable
            if self._stopping:
                logging.disable(logging.CRITICAL)
            try:
                self._cluster.close(timeout=10)
            finally:
                logging.disable(disabled)
            self._cluster = None
        self._stopping = False

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._release(exc)

    def _release(self, exc: BaseException | None) -> None:
        if isinstance(exc, KeyboardInterrupt):  # Ctrl-C, or SIGTERM (signals.Terminated)
            self._stop_quietly()
        self.close()

    def _stop_quietly(self) -> None:
        """Before an interruption stops the LocalCluster: its workers log nothing more."""
        if self._stopping or self._cluster is None or self._client is None:
            return
        self._stopping = True
        if self._client.status == "running":
            with contextlib.suppress(OSError, TimeoutError, RuntimeError):
                # callback_timeout: Client.sync's limit (run's own keywords go to _hush)
                self._client.run(_hush, callback_timeout=5)

    @property
    def client(self) -> Any:
        """The ``distributed.Client`` (inside the ``with`` block)."""
        if self._client is None:
            msg = "the Dask engine is not started; use it as `with DaskEngine(...) as engine:`"
            raise EngineError(msg)
        return self._client

    def describe(self) -> str:
        n = len(self.client.scheduler_info(n_workers=-1)["workers"])
        return f"the Dask cluster at {self._address} ({n} worker(s))"

    def _check_workers(self) -> None:
        client = self.client
        try:
            client.wait_for_workers(1, timeout=self.workers_timeout_s)
        except TimeoutError as exc:
            msg = (
                f"the Dask scheduler at {self._address} has no workers after "
                f"{self.workers_timeout_s:.0f} s; expected at least one: start "
                f"`dask worker {self._address} --nthreads 1` on each machine"
            )
            raise EngineError(msg) from exc
        info = client.scheduler_info(n_workers=-1)["workers"]
        threaded = sorted(a for a, w in info.items() if int(w.get("nthreads", 1)) != 1)
        if threaded:
            msg = (
                f"Dask worker(s) {', '.join(threaded)} run {info[threaded[0]]['nthreads']} "
                "threads; expected 1: tasks are CPU-bound Python with one PyBullet world per "
                "process, so start workers with `--nthreads 1 --nworkers N` (N = cores)"
            )
            raise EngineError(msg)
        trimmed = sorted(a for a, v in client.run(os.environ.get, _TRIM_ENV).items()
                         if v is not None)
        if trimmed:
            warnings.warn(
                f"Dask worker(s) {', '.join(trimmed)} run with {_TRIM_ENV} set (the Dask "
                "nanny's default), which turns off glibc's adaptive mmap threshold and slowed "
                "generation by ~40% on our machine; start the workers with "
                f"`{_TRIM_KEY}: null` in their Dask config (see docs/scale-out.md)",
                RuntimeWarning, stacklevel=2)
        mine = software()
        for address, theirs in sorted(client.run(software).items()):
            for key, value in mine.items():
                if value != "not installed" and theirs.get(key) != value:
                    msg = (
                        f"Dask worker {address} has {key} {theirs.get(key)}, this process "
                        f"{value}; expected the same versions everywhere (other versions can "
                        "write other bytes): install the same nsrmp-bench environment on "
                        "every machine"
                    )
                    raise EngineError(msg)

    def require_shared_dir(self, path: Path) -> None:
        path = Path(path).resolve()
        probe = path / f".nsrmp-bench-probe-{uuid.uuid4().hex}"
        probe.write_text("probe\n", "utf-8")
        try:
            seen = self.client.run(os.path.isfile, str(probe))
        finally:
            probe.unlink(missing_ok=True)
        blind = sorted(a for a, ok in seen.items() if not ok)
        if blind:
            msg = (
                f"Dask worker(s) {', '.join(blind)} cannot see {path}; expected a directory "
                "on a filesystem every worker shares, at the same path: put the data on "
                "the shared filesystem (NFS, Lustre ...) and give that path"
            )
            raise EngineError(msg)

    # -- running -------------------------------------------------------------------
    def _run(self, fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]],
             tally: ProgressTally) -> Iterator[tuple[int, tuple[Any, int]]]:
        client = self.client
        run_id = uuid.uuid4().hex[:12]
        topic = f"nsrmp-bench-progress-{run_id}"
        inbox: queue_module.SimpleQueue[tuple[int, int]] = queue_module.SimpleQueue()
        client.subscribe_topic(topic, lambda event: inbox.put(tuple(event[1])))
        sink = _EventSink(topic)
        futures = {
            client.submit(run_task, fn, args, TaskReport(k, sink, _PROGRESS_S),
                          key=f"{fn.__name__}-{k}-{run_id}", pure=False): k
            for k, args in enumerate(tasks)
        }
        pending = set(futures)
        ready: list[Any] = []
        lost_at: float | None = None
        try:
            while pending or ready:
                if pending:
                    try:
                        with client.as_current():
                            finished, not_done = self._dd.wait(
                                list(pending), timeout=_POLL_S, return_when="FIRST_COMPLETED")
                        pending = set(not_done)
                        ready.extend(finished)
                    except TimeoutError:
                        pass
                    except (CancelledError, self._dd.comm.CommClosedError) as exc:  # Dask
                        # cancels them all, or a comm closes, when it loses the scheduler
                        raise self._lost(client.status, len(tasks) - len(pending),
                                         len(tasks)) from exc
                while not inbox.empty():
                    tally.update(*inbox.get())
                if client.status != "running":
                    lost_at = time.monotonic() if lost_at is None else lost_at
                    if time.monotonic() - lost_at > self.lost_grace_s:
                        raise self._lost(client.status, len(tasks) - len(pending), len(tasks))
                    time.sleep(_POLL_S)
                    continue
                lost_at = None
                while ready:
                    fut = ready.pop()
                    k = futures[fut]
                    yield k, self._result(fut, tasks[k], len(tasks) - len(pending), len(tasks))
        except KeyboardInterrupt:  # before the cancellations below are logged
            self._stop_quietly()
            raise
        finally:
            if client.status == "running":
                client.cancel(list(pending))
                client.unsubscribe_topic(topic)

    def _result(self, fut: Future[Any], args: tuple[Any, ...], done: int, total: int) -> Any:
        try:
            return fut.result()
        except self._dd.KilledWorker as exc:
            msg = (
                f"task {fut.key} (arguments {args!r}) was running on every worker that died "
                f"({exc}); Dask stopped retrying it: it probably kills its worker (memory "
                f"limit?); look at the workers' logs, then {_RERUN}"
            )
            raise EngineError(msg) from exc
        except (CancelledError, self._dd.comm.CommClosedError) as exc:  # lost mid-gather
            raise self._lost(self.client.status, done, total) from exc

    def _lost(self, status: str, done: int, total: int) -> EngineError:
        msg = (
            f"the Dask scheduler at {self._address} went away (client {status!r}) when "
            f"{done} of {total} tasks had finished; "
            f"expected it to run until the end: start the scheduler and workers again (or "
            f"drop --scheduler for a LocalCluster) and {_RERUN}"
        )
        return EngineError(msg)
