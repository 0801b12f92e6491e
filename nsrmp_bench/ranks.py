"""Ranks that do not pretend: entries whose intervals overlap share a rank.

The reference rows (the registered baselines: oracle, noop, random) are bounds and get no
rank. The other rows of a board, in IoU-M order, are ranked by position; an entry whose
95% interval overlaps the interval of the first entry of its group (the group's leader)
shares the leader's rank, marked "=", and the first entry that does not overlap the
leader starts a new group at its own position. Comparing with the leader, not with the
previous entry, keeps a long chain of small steps from tying the whole board. Needs only
the standard library (the Markdown boards and the site both use it).

A row's ``kind`` says whether it is a reference: :data:`REFERENCE_KIND`, the kind every
registered baseline's row has (:func:`is_reference`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, SupportsFloat

__all__ = ["RANK_RULE", "REFERENCE_KIND", "is_reference", "rank_metric", "rank_rule",
           "shared_ranks"]

REFERENCE_KIND = "baseline"
"""The ``kind`` of a reference row (a registered baseline's): not ranked."""


def is_reference(kind: str) -> bool:
    """Whether a row of this ``kind`` is a reference (a registered baseline)."""
    return kind == REFERENCE_KIND


RANK_RULE = ("Ranks: the reference rows (oracle, noop, random) are bounds and are not "
             "ranked. The other entries are ranked by IoU-M; an entry whose 95% interval "
             "overlaps the interval of the first entry of its group (the group's leader) "
             "shares the leader's rank, marked “=”, and the next entry outside it takes "
             "its own position (1=, 1=, 3, …).")


def rank_metric(rows: Sequence[Mapping[str, Any]]) -> str:
    """The figure a board ranks by: IoU-M, or strict success on a board of a part with
    phenomena (semantics-v1), where IoU-M is undefined wherever nothing is to move."""
    return "success_strict" if any(row.get("phenomena") for row in rows) else "iou_m"


def rank_rule(metric: str = "iou_m") -> str:
    """:data:`RANK_RULE` for a board ranked by ``metric``."""
    if metric == "iou_m":
        return RANK_RULE
    return RANK_RULE.replace(
        "ranked by IoU-M", "ranked by strict success (IoU-M is undefined where nothing "
        "is to move)")


def _finite(value: SupportsFloat | None) -> bool:
    return value is not None and math.isfinite(float(value))


def shared_ranks(rows: Sequence[Mapping[str, Any]], metric: str | None = None) -> list[str]:
    """The rank shown for each row of a board in the order of ``metric`` (default:
    :func:`rank_metric`; "" for a reference row, "2=" for a shared rank), by
    :func:`rank_rule`."""
    metric = metric or rank_metric(rows)
    ranks: list[int | None] = []
    leader: tuple[int, float, float] | None = None
    position = 0
    for row in rows:
        if is_reference(str(row["kind"])):
            ranks.append(None)
            continue
        position += 1
        triple = row["metrics"].get(metric) or [None, None, None]
        low, high = triple[1], triple[2]
        if not (_finite(low) and _finite(high)):
            leader = None
            ranks.append(position)
        elif leader is not None and low <= leader[2] and leader[1] <= high:
            ranks.append(leader[0])
        else:
            leader = (position, float(low), float(high))
            ranks.append(position)
    counts = {r: ranks.count(r) for r in ranks if r is not None}
    return ["" if r is None else f"{r}=" if counts[r] > 1 else str(r) for r in ranks]
