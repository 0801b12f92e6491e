"""One writer per folder: a lock file that a second writer finds held, and says so.

``generate`` resumes a part folder by removing its unfinished ``*.tmp`` files and checking
its shards; a second ``generate`` into the same folder at the same time would remove the
first one's files as they are written. :func:`folder_lock` takes an exclusive lock on
``FOLDER/.nsrmp-bench.lock`` (``fcntl.flock``, released by the kernel when the process
ends, however it ends) and refuses, with a sentence naming the folder and the holder's
process id, when another process holds it. The file is removed when the work ends, so a
finished folder holds only its data.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from nsrmp_bench.errors import ResourceLimit

__all__ = ["LOCK_NAME", "folder_lock"]

LOCK_NAME = ".nsrmp-bench.lock"


def _held(fd: int, folder: Path, what: str) -> ResourceLimit:
    holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
    return ResourceLimit(
        f"{str(folder)!r} is being written by another {what} (process {holder}); expected "
        "one writer per folder: wait for it to finish (it resumes what is there), or write "
        "into another folder")


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str], what: str) -> Iterator[None]:
    """Hold the lock of ``folder`` (created when missing) while the block runs; ``what``
    names the work in the message (``"generate"``). Where file locks are not supported
    (no ``fcntl``), the block runs unlocked."""
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks here
        yield
        return
    base = Path(folder)
    path = base / LOCK_NAME
    base.mkdir(parents=True, exist_ok=True)
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            error = _held(fd, base, what)
            os.close(fd)
            raise error from None
        try:
            current = os.stat(path).st_ino
        except FileNotFoundError:
            current = -1
        if current == os.fstat(fd).st_ino:
            break
        os.close(fd)  # the holder removed it as we opened it: lock the new one
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        with contextlib.suppress(OSError):
            path.unlink()
        os.close(fd)  # closing releases the lock
