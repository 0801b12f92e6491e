"""The protocol a predictions file was made under: what the model learned from and on which
data, stated in its header and in its leaderboard entry, and checked.

A predictions header (and a leaderboard entry) carries ``"protocol"``::

    {"supervision": "initial and final boxes",      what the model learned from
     "boxes": "gold",                               or "detected:<detector id>"
     "training_parts": ["paper-v2/train", "paper-v2/val"],   parts it learned or was
                                                    selected on ([] for none)
     "seeds": [0],                                  training seeds ([] for none)
     "scorer": "scorer-v1",                         the scorer version it is scored with
     "manifest_root_hash": "<64 hex>"}              root hash of the part it was made on

``manifest_root_hash`` is the root hash of the manifest of the part the predictions were
made on (an inputs-only pack of a part has the part's root hash): a file made on another
part, or on another version of it, is refused by ``check-submission`` and the
leaderboard, naming both hashes.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.version import KNOWN_SCORERS
from nsrmp_bench.storage.manifest import MANIFEST_NAME, read_manifest
from nsrmp_bench.storage.split_root import resolve_part

__all__ = ["GOLD_BOXES", "PROTOCOL_KEYS", "ProtocolFields", "detected_boxes",
           "manifest_mismatch", "part_root_hash"]

PROTOCOL_KEYS = ("supervision", "boxes", "training_parts", "seeds", "scorer",
                 "manifest_root_hash")
"""The fields of ``"protocol"``, in the order they are shown."""
GOLD_BOXES = "gold"
_DETECTED = "detected:"
_PART_RE = re.compile(r"^[a-z][a-z0-9]*-v[0-9]+/[a-z][a-z0-9_-]*$")
_HASH_RE = re.compile(r"^[0-9a-f]{64}$")
_EXAMPLE = ('{"supervision": "initial and final boxes", "boxes": "gold", "training_parts": '
            '["paper-v2/train", "paper-v2/val"], "seeds": [0], "scorer": "scorer-v1", '
            '"manifest_root_hash": "<the root hash in the part\'s manifest.json>"}')


def _text(v: object) -> bool:
    return isinstance(v, str) and bool(v.strip())


def _boxes(v: object) -> bool:
    return isinstance(v, str) and (v == GOLD_BOXES
                                   or (v.startswith(_DETECTED) and len(v) > len(_DETECTED)))


def _parts(v: object) -> bool:
    return isinstance(v, list) and all(isinstance(p, str) and _PART_RE.match(p) for p in v)


def _seeds(v: object) -> bool:
    return isinstance(v, list) and all(
        isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in v)


def _hash(v: object) -> bool:
    return isinstance(v, str) and bool(_HASH_RE.match(v))


_CHECKS: tuple[tuple[str, Callable[[Any], bool], str], ...] = (
    ("supervision", _text, "a non-empty text saying what the model learned from (e.g. "
     "'initial and final boxes', 'none (not learned)')"),
    ("boxes", _boxes, f"{GOLD_BOXES!r} or 'detected:<detector id>' (e.g. "
     "'detected:detector-v1')"),
    ("training_parts", _parts, "a list of split parts such as 'paper-v2/train' ([] for a "
     "model that learned nothing)"),
    ("seeds", _seeds, "a list of non-negative integers ([] for none)"),
    ("scorer", lambda v: v in KNOWN_SCORERS, f"one of {list(KNOWN_SCORERS)}"),
    ("manifest_root_hash", _hash, "the 64 hex digits of 'root_hash' in the manifest.json "
     "of the part the predictions were made on"),
)


def detected_boxes(detector: str) -> str:
    """The ``boxes`` value of a model that read boxes from ``detector``."""
    return f"{_DETECTED}{detector}"


@dataclass(frozen=True)
class ProtocolFields:
    """The checked protocol of one predictions file or leaderboard entry."""

    supervision: str
    boxes: str
    training_parts: tuple[str, ...]
    seeds: tuple[int, ...]
    scorer: str
    manifest_root_hash: str

    def to_dict(self) -> dict[str, Any]:
        """The JSON object (``"protocol"``)."""
        return {"supervision": self.supervision, "boxes": self.boxes,
                "training_parts": list(self.training_parts), "seeds": list(self.seeds),
                "scorer": self.scorer, "manifest_root_hash": self.manifest_root_hash}

    @classmethod
    def from_dict(cls, data: object, where: str) -> ProtocolFields:
        """Parse and check ``"protocol"``; a bad field is named with the expected form."""
        if not isinstance(data, Mapping):
            msg = f"{where}: 'protocol' is {data!r:.60}; expected an object like {_EXAMPLE}"
            raise InvalidArgument(msg)
        missing = [k for k in PROTOCOL_KEYS if k not in data]
        extra = sorted(set(data) - set(PROTOCOL_KEYS))
        if missing or extra:
            msg = (f"{where}: 'protocol' lacks {missing} and has unknown {extra}; it holds "
                   f"exactly {list(PROTOCOL_KEYS)}, e.g. {_EXAMPLE}")
            raise InvalidArgument(msg)

        for key, ok, expected in _CHECKS:
            if not ok(data[key]):
                msg = f"{where}: protocol field {key!r} is {data[key]!r:.80}; expected {expected}"
                raise InvalidArgument(msg)
        supervision, boxes, parts, seeds, scorer, root = (data[k] for k in PROTOCOL_KEYS)
        return cls(str(supervision), str(boxes), tuple(parts), tuple(seeds), str(scorer),
                   str(root))


def manifest_mismatch(fields: ProtocolFields, root_hash: str, part: str, where: str
                      ) -> str | None:
    """Why predictions stating ``fields`` were not made on ``part`` (whose manifest's root
    hash is ``root_hash``), or None."""
    if fields.manifest_root_hash == root_hash:
        return None
    return (f"{where} was made on another manifest: its protocol names the part with root "
            f"hash {fields.manifest_root_hash[:16]}..., but {part} has root hash "
            f"{root_hash[:16]}...; predict again on {part}'s data (its manifest.json), or "
            "check the file against the part it was made on")


def part_root_hash(data: str | os.PathLike[str], part: str | None = None) -> str | None:
    """The root hash of the part ``data`` (a part directory, or a split root with ``part``);
    None when it has no manifest (a single shard file)."""
    folder = resolve_part(data, part)
    if not (folder / MANIFEST_NAME).is_file():
        return None
    return read_manifest(folder).root_hash
