"""A file's sha256, computed once per file identity in a process.

Checking gold against its manifest before scoring reads every shard; a process that scores
many files on one part (the leaderboard, an EvalAI worker) hashes each shard once. The
identity is the resolved path, size, modification time (ns) and inode: a file rewritten in
place, even to the same size, is hashed again.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

from nsrmp_bench.canonical import sha256_file

__all__ = ["file_identity", "sha256_once"]

_Identity = tuple[str, int, int, int]
_known: dict[_Identity, str] = {}
_lock = threading.Lock()


def file_identity(path: str | os.PathLike[str]) -> _Identity:
    """``(resolved path, size, mtime_ns, inode)`` of ``path``."""
    p = Path(path).resolve()
    st = p.stat()
    return str(p), st.st_size, st.st_mtime_ns, st.st_ino


def sha256_once(path: str | os.PathLike[str]) -> str:
    """The hex sha256 of ``path``, from this process's cache when its identity is unchanged."""
    key = file_identity(path)
    with _lock:
        known = _known.get(key)
    if known is not None:
        return known
    digest = sha256_file(path)
    if file_identity(path) == key:  # unchanged while it was read
        with _lock:
            _known[key] = digest
    return digest
