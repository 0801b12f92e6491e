"""Referring expressions: how a program names an object, and their DSL nodes.

A :class:`Reference` names an object by attributes (colour, shape, or both), by one
relation to an anchor object that is itself named by attributes, or by a superlative over
the objects its attributes name ("the leftmost cube": ``extreme`` and ``rank``). The
``*_references`` functions list every reference of a kind that picks out exactly one object
in a given state; :func:`compile_reference` appends the reference's nodes to a program under
construction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from nsrmp_bench.dsl.program import Node
from nsrmp_bench.dsl.relations import ranked, related
from nsrmp_bench.errors import AmbiguousReference, InvalidReference
from nsrmp_bench.scene import SceneObject, State
from nsrmp_bench.vocabulary import RELATIONS

__all__ = [
    "Reference",
    "attribute_references",
    "compile_reference",
    "relational_references",
    "superlative_references",
]


@dataclass(frozen=True)
class Reference:
    """Colour and/or shape filters, optionally over the objects in ``relation`` of ``anchor``."""

    colour: str | None = None
    shape: str | None = None
    relation: str | None = None
    anchor: Reference | None = None
    extreme: str | None = None
    """The side of a superlative (``left``: the leftmost); None for other references."""
    rank: int = 1
    """A superlative's rank from that side (1 = the most, 2 = the second from it)."""

    @property
    def relational(self) -> bool:
        """Whether the reference goes through a relation."""
        return self.relation is not None

    @property
    def form(self) -> str:
        """Which attribute filters it uses: none, colour, shape or both."""
        if self.colour and self.shape:
            return "both"
        return "colour" if self.colour else "shape" if self.shape else "none"


def _matches(obj: SceneObject, colour: str | None, shape: str | None) -> bool:
    return (colour is None or obj.colour == colour) and (shape is None or obj.shape == shape)


def attribute_references(objects: Sequence[SceneObject], target: int) -> list[Reference]:
    """Attribute-only references that pick out ``target`` alone (state-independent)."""
    obj = objects[target]
    out = []
    for colour, shape in ((obj.colour, obj.shape), (obj.colour, None), (None, obj.shape)):
        hits = [i for i, o in enumerate(objects) if _matches(o, colour, shape)]
        if hits == [target]:
            out.append(Reference(colour, shape))
    return out


def relational_references(
    objects: Sequence[SceneObject], state: State, target: int
) -> list[Reference]:
    """References through one relation to an attribute-named anchor that pick out ``target``."""
    obj = objects[target]
    out: list[Reference] = []
    for anchor in range(len(objects)):
        if anchor == target:
            continue
        anchors = attribute_references(objects, anchor)
        if not anchors:
            continue
        for relation in RELATIONS:
            members = related(state, anchor, relation)
            if target not in members:
                continue
            for colour, shape in ((None, None), (None, obj.shape), (obj.colour, None),
                                  (obj.colour, obj.shape)):
                hits = [i for i in members if _matches(objects[i], colour, shape)]
                if hits == [target]:
                    out.extend(Reference(colour, shape, relation, a) for a in anchors)
                    break  # the fewest filters that work
    return out


def superlative_references(
    objects: Sequence[SceneObject], state: State, target: int, *, max_rank: int = 2
) -> list[Reference]:
    """Superlatives over an attribute-named set of at least two objects that pick out
    ``target`` on ``state`` (rank up to ``max_rank``, each apart from its neighbours)."""
    obj = objects[target]
    out = []
    for colour, shape in ((None, obj.shape), (obj.colour, None), (None, None)):
        members = [i for i, o in enumerate(objects) if _matches(o, colour, shape)]
        if len(members) < 2:
            continue
        for side in RELATIONS:
            for rank in range(1, min(max_rank, len(members)) + 1):
                try:
                    if ranked(state, members, side, rank) == target:
                        out.append(Reference(colour, shape, extreme=side, rank=rank))
                except (InvalidReference, AmbiguousReference):
                    continue
    return out


def compile_reference(ref: Reference, nodes: list[Node]) -> int:
    """Append ``ref``'s nodes to ``nodes``; returns the index of its ``unique`` (or, for a
    superlative, ``extreme``) node."""
    if ref.anchor is not None and ref.relation is not None:
        anchor = compile_reference(ref.anchor, nodes)
        nodes.append(Node("relate", (anchor,), (ref.relation,)))
    else:
        nodes.append(Node("scene"))
    for concept in (ref.shape, ref.colour):
        if concept is not None:
            nodes.append(Node("filter", (len(nodes) - 1,), (concept,)))
    if ref.extreme is not None:
        nodes.append(Node("extreme", (len(nodes) - 1,), (ref.extreme, str(ref.rank))))
    else:
        nodes.append(Node("unique", (len(nodes) - 1,)))
    return len(nodes) - 1
