"""Spatial relations between objects, on a given world state.

Object j is R of object i iff (p_j - p_i) . axis(R) > RELATION_THRESHOLD, computed on
object centres (the original's definition; see vocabulary.RELATION_AXES).
"""

from __future__ import annotations

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scene import State
from nsrmp_bench.vocabulary import RELATION_AXES, RELATION_THRESHOLD

__all__ = ["related"]


def related(state: State, anchor: int, relation: str) -> frozenset[int]:
    """Indices of the objects that are ``relation`` of object ``anchor`` in ``state``."""
    axis = RELATION_AXES.get(relation)
    if axis is None:
        msg = f"unknown relation {relation!r}; expected one of {sorted(RELATION_AXES)}"
        raise InvalidArgument(msg)
    pa = state[anchor].position
    out = set()
    for j, pose in enumerate(state):
        if j == anchor:
            continue
        d = sum((pose.position[k] - pa[k]) * axis[k] for k in range(3))
        if d > RELATION_THRESHOLD:
            out.add(j)
    return frozenset(out)
