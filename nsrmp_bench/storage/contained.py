"""Paths that arrive from outside stay inside the folder they are meant for.

A mirror's registry, an archive's member names, a leaderboard entry's ``model_card`` and
``predictions``: each names a path relative to a folder the package writes into or copies
from. :func:`inside` resolves such a name against its folder, following symbolic links,
and refuses with one sentence (the value, what was expected, the fix) any name that is
absolute, climbs out with ``..``, uses a backslash or a drive, or leads out through a link.
"""

from __future__ import annotations

import os
from pathlib import Path, PurePosixPath

from nsrmp_bench.errors import NSRMPError, UnsafePath

__all__ = ["inside", "plain_name"]


def _refuse(error: type[NSRMPError], what: str, value: str, why: str, root: Path,
            fix: str) -> NSRMPError:
    return error(f"{what} {value!r} {why}; expected a path inside {str(root)!r}: {fix}")


def inside(root: str | os.PathLike[str], name: str, *, what: str, fix: str,
           error: type[NSRMPError] = UnsafePath) -> Path:
    """``root / name`` if it stays inside ``root`` once resolved; else ``error``.

    ``name`` is a relative POSIX path (``part/file.h5``); refused are an empty name, an
    absolute path, a backslash, a NUL byte, a ``..`` that climbs above ``root``, and a path
    whose resolved place (links followed, for the parts that exist) lies outside ``root``.
    ``what`` names the value in the message (``"registry entry"``), ``fix`` says what to do.
    """
    base = Path(root)
    if not name or "\x00" in name:
        raise _refuse(error, what, name, "is empty or holds a NUL byte", base, fix)
    if "\\" in name or (len(name) > 1 and name[1] == ":"):
        raise _refuse(error, what, name, "uses a backslash or a drive letter", base, fix)
    pure = PurePosixPath(name)
    if pure.is_absolute():
        raise _refuse(error, what, name, "is an absolute path", base, fix)
    if ".." in pure.parts:
        raise _refuse(error, what, name, "climbs out with '..'", base, fix)
    target = base.joinpath(*pure.parts)
    real_root = base.resolve()
    if not target.resolve().is_relative_to(real_root):
        raise _refuse(error, what, name,
                      f"leads outside through a link (to {str(target.resolve())!r})", base, fix)
    return target


def plain_name(name: str, *, what: str, fix: str,
               error: type[NSRMPError] = UnsafePath) -> str:
    """``name`` if it is one plain file name (no folder, not hidden); else ``error``."""
    if (not name or "/" in name or "\\" in name or "\x00" in name or name.startswith(".")
            or (len(name) > 1 and name[1] == ":")):
        msg = (f"{what} {name!r} is not a plain file name (no folder, no leading dot); "
               f"{fix}")
        raise error(msg)
    return name
