"""Referring expressions: how a program names an object, and their DSL nodes.

A :class:`Reference` names an object by attributes (colour, shape, or both) or by one
relation to an anchor object that is itself named by attributes. :func:`describe` lists
every reference that picks out exactly one object in a given state; :func:`compile_reference`
appends the reference's nodes to a program under construction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from nsrmp_bench.dsl.program import Node
from nsrmp_bench.dsl.relations import related
from nsrmp_bench.scene import SceneObject, State
from nsrmp_bench.vocabulary import RELATIONS

__all__ = ["Reference", "attribute_references", "compile_reference", "relational_references"]


@dataclass(frozen=True)
class Reference:
    """Colour and/or shape filters, optionally over the objects in ``relation`` of ``anchor``."""

    colour: str | None = None
    shape: str | None = None
    relation: str | None = None
    anchor: Reference | None = None

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


def compile_reference(ref: Reference, nodes: list[Node]) -> int:
    """Append ``ref``'s nodes to ``nodes``; returns the index of its ``unique`` node."""
    if ref.anchor is not None and ref.relation is not None:
        anchor = compile_reference(ref.anchor, nodes)
        nodes.append(Node("relate", (anchor,), (ref.relation,)))
    else:
        nodes.append(Node("scene"))
    for concept in (ref.shape, ref.colour):
        if concept is not None:
            nodes.append(Node("filter", (len(nodes) - 1,), (concept,)))
    nodes.append(Node("unique", (len(nodes) - 1,)))
    return len(nodes) - 1
