"""Looking up a versioned id (``name-vN``) by its id or by its bare name.

Baselines and learned models share this rule: an exact id wins; a bare name means its
latest version; anything else is an :class:`UnknownId` with a did-you-mean.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from nsrmp_bench.errors import UnknownId

__all__ = ["resolve_id"]


def _version(key: str) -> int:
    tail = key.rsplit("-v", 1)[-1]
    return int(tail) if tail.isdigit() else -1


def resolve_id(name: str, known: Iterable[str], kind: str) -> str:
    """The id among ``known`` that ``name`` means; ``kind`` names them in the error."""
    ids = list(known)
    if name in ids:
        return name
    versions = sorted((k for k in ids if k.rsplit("-v", 1)[0] == name), key=_version,
                      reverse=True)
    if versions:
        return versions[0]
    names = [*ids, *(k.rsplit("-v", 1)[0] for k in ids)]
    close = difflib.get_close_matches(name, names, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    msg = f"unknown {kind} {name!r}{hint} Known {kind}s: {', '.join(ids)}"
    raise UnknownId(msg)
