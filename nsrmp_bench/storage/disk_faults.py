"""The machine's faults said as sentences: a full disk, a read-only folder, no permission.

Every writer goes through a temporary file renamed into place
(:mod:`nsrmp_bench.storage.atomic`), so a fault leaves nothing that looks complete; what is
left is to tell the user, in one sentence, which path could not be written, why, and what to
do. :func:`disk_fault` turns such an :class:`OSError` (h5py's included, which names the
errno in its text) into that sentence; the command line prints it and exits 2.
"""

from __future__ import annotations

import errno
import re

__all__ = ["DISK_FAULT_ERRNOS", "disk_fault"]

_FIXES = {
    errno.ENOSPC: ("the disk is full", "free space there, or write to another disk"),
    errno.EDQUOT: ("the disk quota is used up", "free space there, or write elsewhere"),
    errno.EFBIG: ("the file would pass the largest size allowed here",
                  "write to another file system, or lift the file size limit"),
    errno.EROFS: ("the folder is on a read-only file system",
                  "choose a writable output folder"),
    errno.EACCES: ("permission is denied", "choose a folder you may write, or fix its "
                   "permissions"),
    errno.EPERM: ("the operation is not permitted", "choose a folder you may write"),
}
DISK_FAULT_ERRNOS = frozenset(_FIXES)
"""The errno values :func:`disk_fault` has a sentence for."""
_ERRNO_IN_TEXT = re.compile(r"errno = (\d+)|\[Errno (\d+)\]")
_FILENAME_IN_TEXT = re.compile(r"filename = '([^']+)'")


def _errno_of(exc: OSError) -> int | None:
    if exc.errno is not None:
        return exc.errno
    found = _ERRNO_IN_TEXT.search(str(exc))
    if found is None:
        return None
    return int(found.group(1) or found.group(2))


def disk_fault(exc: BaseException) -> str | None:
    """The sentence for a disk fault (full, read-only, no permission), or None when
    ``exc`` is not one (a bug then surfaces as itself)."""
    if not isinstance(exc, OSError):
        return None
    code = _errno_of(exc)
    if code not in _FIXES:
        return None
    what, fix = _FIXES[code]
    named = _FILENAME_IN_TEXT.search(str(exc))  # h5py names the file in its text only
    where = exc.filename or (named.group(1) if named else "a file of this command")
    return (f"could not write {str(where)!r}: {what} ({errno.errorcode.get(code, code)}); "
            f"nothing was left half-written under its final name: {fix}, then run the same "
            "command again")
