"""Atomic writes: the one way every writer of the package puts a file on disk.

A file is written as ``NAME.<pid>-<random>.tmp`` next to its final place, flushed and
fsynced, renamed to ``NAME`` and its folder fsynced; a write that fails or is interrupted
removes its ``.tmp``, so no file that looks complete is ever half-written. The parent folder
is created when missing. :func:`check_output_file` and :func:`check_output_dir` refuse,
before any work, a folder where a file is meant, a file where a folder is meant, or a path
under a file; the command line checks its output options with them (``type=output_file``),
so that a long run does not end in ``IsADirectoryError`` after all its work.
"""

from __future__ import annotations

import argparse
import os
import secrets
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.errors import InvalidArgument

__all__ = [
    "TMP_SUFFIX",
    "atomic_open",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_dir",
    "check_output_file",
    "fsync_dir",
    "fsync_hashing",
    "output_dir",
    "output_file",
]

TMP_SUFFIX = ".tmp"


def fsync_dir(directory: Path) -> None:
    """fsync a directory so a rename in it is durable (no-op where unsupported)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def fsync_hashing(path: Path) -> str:
    """fsync the closed file ``path`` and return its hex sha256, the hash read while another
    thread waits for the disk (both let go of the GIL): a shard's commit waits for the
    longer of the two, not their sum. The bytes hashed are the file's, written or not yet."""
    failed: list[BaseException] = []

    def sync() -> None:
        try:
            with open(path, "rb+") as fh:
                os.fsync(fh.fileno())
        except BaseException as exc:  # raised below, in the caller's thread
            failed.append(exc)

    syncing = threading.Thread(target=sync, name=f"fsync {path.name}", daemon=True)
    syncing.start()
    try:
        sha = sha256_file(path)
    finally:
        syncing.join()
    if failed:
        raise failed[0]
    return sha


def _file_above(path: Path) -> Path | None:
    """The first existing ancestor of ``path`` that is not a folder, if any."""
    for parent in path.absolute().parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def check_output_file(path: str | os.PathLike[str]) -> Path:
    """``path`` as a :class:`Path` if a file can be written there; else :class:`InvalidArgument`.

    Refused: an existing folder, and a path under an existing file. A missing parent folder
    is fine (the write creates it).
    """
    p = Path(path)
    if p.is_dir():
        msg = (f"{str(p)!r} is a folder, but a file is meant here: name the file to "
               f"write, e.g. {str(p / 'NAME')!r}")
        raise InvalidArgument(msg)
    above = _file_above(p)
    if above is not None:
        msg = (f"cannot write {str(p)!r}: {str(above)!r} is a file, not a folder; "
               "choose another path")
        raise InvalidArgument(msg)
    return p


def check_output_dir(path: str | os.PathLike[str]) -> Path:
    """``path`` as a :class:`Path` if it is or may become a folder; else InvalidArgument."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        msg = (f"{str(p)!r} is a file, but a folder is meant here: name a folder "
               "(it is created when missing)")
        raise InvalidArgument(msg)
    above = _file_above(p)
    if above is not None:
        msg = (f"cannot make the folder {str(p)!r}: {str(above)!r} is a file, not a "
               "folder; choose another path")
        raise InvalidArgument(msg)
    return p


def _argparse_type(check: Callable[[str], Path], name: str) -> Callable[[str], Path]:
    def convert(value: str) -> Path:
        try:
            return check(value)
        except InvalidArgument as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = name  # argparse names the type in its messages
    return convert


output_file = _argparse_type(check_output_file, "output file")
"""An argparse ``type=`` for an output file (:func:`check_output_file` at parse time)."""
output_dir = _argparse_type(check_output_dir, "output folder")
"""An argparse ``type=`` for an output folder (:func:`check_output_dir` at parse time)."""


@contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield the ``.tmp`` path to write ``path`` through; commit it when the block ends.

    The temporary name is unique (``NAME.<pid>-<random>.tmp``), so two writers of one path
    never write into each other's file: the last to finish wins, whole.

    The block writes the temporary file by any means (a library's ``write(tmp)``); on
    success it is fsynced and renamed to ``path`` and the folder fsynced; on any exception
    (Ctrl-C and SIGTERM included) it is removed. The parent folder is created.
    """
    out = check_output_file(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f"{out.name}.{os.getpid()}-{secrets.token_hex(4)}{TMP_SUFFIX}")
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if exc.filename is None and exc.errno is not None:  # a failed flush names no file
            raise OSError(exc.errno, exc.strerror, str(out)) from exc
        raise
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_dir(out.parent)


@contextmanager
def atomic_open(path: str | os.PathLike[str]) -> Iterator[TextIO]:
    """Open ``path`` for writing text (UTF-8) through :func:`atomic_path`."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        yield fh


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
