"""The protocol fields of the shipped checkpoints (``protocols.json`` beside this module):
what each learned from, the parts it was trained or selected on and its seeds, joined with
a detector's when the model read detected boxes. ``predict`` writes them into the headers
it makes with a shipped checkpoint; ``scripts/protocol_fields.py`` into the leaderboard
entries (the retired models' facts stay in the table for their committed entries)."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

from nsrmp_bench.errors import UnknownId
from nsrmp_bench.scoring.protocol_fields import GOLD_BOXES, ProtocolFields, detected_boxes
from nsrmp_bench.scoring.version import WRITTEN_SCORER_ID

__all__ = ["shipped_protocol"]


@cache
def _table() -> dict[str, Any]:
    text = resources.files("nsrmp_bench.reference_model").joinpath("protocols.json")
    data: dict[str, Any] = json.loads(text.read_text("utf-8"))
    return data


def _facts(kind: str, name: str) -> dict[str, Any]:
    known: dict[str, Any] = _table()[kind]
    if name not in known:
        msg = (f"no protocol fields are recorded for the shipped {kind[:-1]} {name!r}; known: "
               f"{sorted(known)} (reference_model/protocols.json)")
        raise UnknownId(msg)
    facts: dict[str, Any] = known[name]
    return facts


def shipped_protocol(model_id: str, manifest_root_hash: str, *, detector: str | None = None
                     ) -> ProtocolFields:
    """The protocol of shipped model ``model_id`` (``nsrm-v3``) run on the part whose root
    hash is ``manifest_root_hash``, on the gold boxes or on ``detector``'s."""
    model = _facts("models", model_id)
    supervision = str(model["supervision"])
    parts = [str(p) for p in model["training_parts"]]
    seeds = [int(s) for s in model["seeds"]]
    if detector is not None:
        det = _facts("detectors", detector)
        supervision += f"; detector {detector}: {det['supervision']}"
        parts += [str(p) for p in det["training_parts"] if p not in parts]
        seeds += [int(s) for s in det["seeds"] if s not in seeds]
    return ProtocolFields(
        supervision=supervision,
        boxes=GOLD_BOXES if detector is None else detected_boxes(detector),
        training_parts=tuple(parts), seeds=tuple(sorted(seeds)), scorer=WRITTEN_SCORER_ID,
        manifest_root_hash=manifest_root_hash,
    )
