"""Split roots: the directory ``generate --out DIR`` writes, holding one directory per part.

``nsrmp-bench generate --split smoke-v2 --out data/smoke`` writes ``data/smoke/test/``
(shards and ``manifest.json``); ``data/smoke`` is then a *split root*. Every reader of data
(:func:`nsrmp_bench.storage.open`, and through it every verb taking ``--data``) accepts a
split root when it knows which part to read (a predictions file's header names it:
``smoke-v2/test``), and otherwise says which parts the root holds and what to pass.
"""

from __future__ import annotations

import os
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.manifest import MANIFEST_NAME

__all__ = ["find_part", "part_of_split", "resolve_part", "split_root_parts"]


def split_root_parts(path: str | os.PathLike[str]) -> tuple[str, ...]:
    """The finished parts (sub-directories with ``manifest.json``) of the split root
    ``path``, sorted; ``()`` when ``path`` is not a directory or is a part itself."""
    p = Path(path)
    if not p.is_dir() or (p / MANIFEST_NAME).is_file():
        return ()
    return tuple(sorted(d.name for d in p.iterdir() if (d / MANIFEST_NAME).is_file()))


def part_of_split(split: str | None) -> str | None:
    """The part a split id names (``test`` for ``smoke-v2/test``), or None."""
    if not split:
        return None
    part = split.partition("/")[2]
    return part or None


def resolve_part(path: str | os.PathLike[str], part: str | None = None) -> Path:
    """``path`` itself, or its part directory when ``path`` is a split root.

    For a split root, ``part`` (e.g. from a predictions header) picks the directory;
    without one, or with one the root does not hold, :class:`InvalidArgument` names the
    parts it holds and what to pass instead.
    """
    p = Path(path)
    if p.name == MANIFEST_NAME and p.is_file():
        return p.parent  # a part's manifest names its part
    parts = split_root_parts(p)
    if not parts:
        if part is not None and (p / part).is_dir() and not (p / MANIFEST_NAME).is_file():
            return p / part  # an unfinished part: its reader says how to finish it
        _refuse_data_root(p)
        return p
    if part in parts:
        return p / part
    listed = ", ".join(parts)
    suggestion = (f"pass {p / parts[0]}" if len(parts) == 1
                  else f"pass one part's directory, e.g. {p / parts[-1]}")
    if part is None:
        msg = f"{p} is a split root holding the parts: {listed}; {suggestion}"
    else:
        msg = (f"{p} is a split root holding the parts: {listed}, not the part {part!r} the "
               f"predictions are for; generate that part (generate --part {part}) or "
               f"{suggestion} with predictions for it")
    raise InvalidArgument(msg)


def _refuse_data_root(p: Path) -> None:
    """A folder of split roots (``data/`` holding ``smoke/test/``...) is not one part."""
    if not p.is_dir() or (p / MANIFEST_NAME).is_file() or any(p.glob("*.h5*")):
        return
    roots = {d.name: split_root_parts(d) for d in sorted(p.iterdir()) if d.is_dir()}
    roots = {name: parts for name, parts in roots.items() if parts}
    if not roots:
        return
    listed = "; ".join(f"{name}/ (parts {', '.join(parts)})" for name, parts in roots.items())
    first = next(iter(roots))
    msg = (f"{p} is a data root holding the split roots {listed}, not one split's data; "
           f"pass one part's directory, e.g. {p / first / roots[first][-1]}")
    raise InvalidArgument(msg)


def find_part(root: str | os.PathLike[str], split_part: str) -> Path | None:
    """The finished data folder of ``split_part`` (``paper-v2/test``) under the data root
    ``root``: ``root/paper-v2/test``, else ``root/paper/test``; None when neither is."""
    split_id, part = split_part.split("/", 1)
    short = split_id.rsplit("-v", 1)[0]
    for folder in (Path(root) / split_id / part, Path(root) / short / part):
        if (folder / MANIFEST_NAME).is_file():
            return folder
    return None
