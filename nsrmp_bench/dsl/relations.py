"""Spatial relations between objects, and superlatives, on a given world state.

Object j is R of object i iff (p_j - p_i) . axis(R) > RELATION_THRESHOLD, computed on
object centres (the original's definition; see vocabulary.RELATION_AXES). The k-th object
of a set towards side R (:func:`ranked`) is the k-th largest (p . axis(R)); it is defined
only when it stands more than EXTREME_MARGIN apart from its neighbours in that order.
"""

from __future__ import annotations

from collections.abc import Iterable

from nsrmp_bench.errors import AmbiguousReference, InvalidArgument, InvalidReference
from nsrmp_bench.scene import State
from nsrmp_bench.vocabulary import EXTREME_MARGIN, RELATION_AXES, RELATION_THRESHOLD

__all__ = ["ranked", "related"]


def _axis(relation: str) -> tuple[float, float, float]:
    axis = RELATION_AXES.get(relation)
    if axis is None:
        msg = f"unknown relation {relation!r}; expected one of {sorted(RELATION_AXES)}"
        raise InvalidArgument(msg)
    return axis


def ranked(state: State, members: Iterable[int], relation: str, rank: int) -> int:
    """The object of ``members`` ranked ``rank`` (1 = the most) towards side ``relation``.

    Raises :class:`InvalidReference` when the set has fewer than ``rank`` objects and
    :class:`AmbiguousReference` when the ranked object is within ``EXTREME_MARGIN`` of a
    neighbour along the axis (nothing tells the two apart).
    """
    axis = _axis(relation)
    if rank < 1:
        msg = f"rank={rank}; a superlative's rank counts from 1 (1 = the most)"
        raise InvalidArgument(msg)
    scored = sorted(
        ((sum(state[j].position[k] * axis[k] for k in range(3)), j) for j in members),
        reverse=True,
    )
    if len(scored) < rank:
        msg = (f"the set has {len(scored)} object(s), so it has no object ranked {rank} "
               f"towards {relation}")
        raise InvalidReference(msg)
    value, chosen = scored[rank - 1]
    near = [j for d, j in (scored[rank - 2:rank - 1] if rank > 1 else []) + scored[rank:rank + 1]
            if abs(d - value) <= EXTREME_MARGIN]
    if near:
        msg = (f"objects {chosen} and {near[0]} are within {EXTREME_MARGIN} m of each other "
               f"towards {relation}: rank {rank} does not tell them apart")
        raise AmbiguousReference(msg)
    return chosen


def related(state: State, anchor: int, relation: str) -> frozenset[int]:
    """Indices of the objects that are ``relation`` of object ``anchor`` in ``state``."""
    axis = _axis(relation)
    pa = state[anchor].position
    out = set()
    for j, pose in enumerate(state):
        if j == anchor:
            continue
        d = sum((pose.position[k] - pa[k]) * axis[k] for k in range(3))
        if d > RELATION_THRESHOLD:
            out.add(j)
    return frozenset(out)
