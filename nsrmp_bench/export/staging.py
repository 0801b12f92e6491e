"""Exports are written into a temporary folder beside the target and renamed when complete.

A killed export leaves only a ``.<name>.partial-*`` folder, never a folder that looks
complete; the target must be new or empty.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument

__all__ = ["check_target", "staged_folder"]


def check_target(out: Path) -> None:
    """Refuse an ``out`` that is a file or a non-empty folder."""
    if out.exists() and not out.is_dir():
        msg = f"--out {str(out)!r} is a file; give a new or empty folder"
        raise InvalidArgument(msg)
    if out.is_dir():
        entries = sorted(p.name for p in out.iterdir())
        if entries:
            shown = ", ".join(entries[:3]) + (" ..." if len(entries) > 3 else "")
            msg = (f"--out {str(out)!r} is not empty ({len(entries)} entries: {shown}); "
                   "give a new folder, or empty this one, so no file of an earlier export "
                   "is mixed in")
            raise InvalidArgument(msg)


@contextmanager
def staged_folder(out: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a fresh temporary folder that becomes ``out`` when the block completes."""
    target = Path(out)
    check_target(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.parent / f".{target.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    check_target(target)
    if target.exists():
        target.rmdir()
    tmp.rename(target)
