"""Programs of the DSL: typed node lists, their text form, and grounded steps.

A program is a list of nodes, each naming an operation of ``signatures.json``, the indices
of earlier nodes it takes as inputs, and its parameters (concept words). The last node is
a ``move`` (or ``idle``); following ``move`` inputs back gives the steps in order.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from nsrmp_bench.errors import BadProgram
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, ORDINALS, RELATIONS, SHAPES

__all__ = [
    "GroundedStep",
    "Node",
    "Program",
    "load_signatures",
    "newest_dsl_version",
]


@cache
def load_signatures() -> dict[str, Any]:
    """The DSL's operation signatures, read from the package data file."""
    text = resources.files("nsrmp_bench.dsl").joinpath("signatures.json").read_text("utf-8")
    data: dict[str, Any] = json.loads(text)
    return data


_PARAM_VALUES: dict[str, tuple[str, ...]] = {
    "concept": (*COLOURS, *SHAPES),
    "relation": RELATIONS,
    "action": ACTIONS,
    "ordinal": ORDINALS,
}


def newest_dsl_version(versions: Iterable[str]) -> str:
    """The newest of DSL version ids (``dsl-vN``); ``dsl-v1`` for none."""
    return max(versions, key=lambda v: int(v.rsplit("-v", 1)[1]), default="dsl-v1")


@dataclass(frozen=True)
class Node:
    """One operation of a program."""

    op: str
    inputs: tuple[int, ...] = ()
    params: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return {"op": self.op, "inputs": list(self.inputs), "params": list(self.params)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Node:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, dict) or "op" not in data:
            msg = f"a program node must be an object with an 'op' key, got {data!r}"
            raise BadProgram(msg)
        try:
            inputs = tuple(int(i) for i in data.get("inputs", ()))
        except (TypeError, ValueError) as exc:
            msg = f"node inputs must be integer node indices, got {data.get('inputs')!r}"
            raise BadProgram(msg) from exc
        return cls(str(data["op"]), inputs, tuple(str(p) for p in data.get("params", ())))


@dataclass(frozen=True)
class Program:
    """A type-checked program: nodes in dependency order."""

    nodes: tuple[Node, ...]

    def __post_init__(self) -> None:
        self.type_check()

    def type_check(self) -> None:
        """Raise :class:`BadProgram` unless every node matches its signature."""
        ops = load_signatures()["operations"]
        if not self.nodes:
            msg = "a program needs at least one node; the smallest program is [idle]"
            raise BadProgram(msg)
        out_types: list[str] = []
        for i, node in enumerate(self.nodes):
            sig = ops.get(node.op)
            if sig is None:
                msg = f"node {i}: unknown operation {node.op!r}; expected one of {sorted(ops)}"
                raise BadProgram(msg)
            if len(node.inputs) != len(sig["inputs"]):
                msg = (
                    f"node {i} ({node.op}) takes {len(sig['inputs'])} inputs, "
                    f"got {len(node.inputs)}: {list(node.inputs)}"
                )
                raise BadProgram(msg)
            for j, (src, want) in enumerate(zip(node.inputs, sig["inputs"], strict=True)):
                if not 0 <= src < i:
                    msg = (
                        f"node {i} ({node.op}) input {j} refers to node {src}; "
                        f"inputs must refer to earlier nodes 0..{i - 1}"
                    )
                    raise BadProgram(msg)
                if out_types[src] != want:
                    msg = (
                        f"node {i} ({node.op}) input {j} needs {want}, but node {src} "
                        f"({self.nodes[src].op}) gives {out_types[src]}"
                    )
                    raise BadProgram(msg)
            if len(node.params) != len(sig["params"]):
                msg = (
                    f"node {i} ({node.op}) takes {len(sig['params'])} parameters, "
                    f"got {list(node.params)}"
                )
                raise BadProgram(msg)
            for value, kind in zip(node.params, sig["params"], strict=True):
                if value not in _PARAM_VALUES[kind]:
                    msg = (
                        f"node {i} ({node.op}): {value!r} is not a {kind}; "
                        f"expected one of {list(_PARAM_VALUES[kind])}"
                    )
                    raise BadProgram(msg)
            out_types.append(sig["output"])
        if out_types[-1] != "action_chain":
            msg = (
                "the last node must give an action_chain (move or idle), "
                f"got {self.nodes[-1].op} giving {out_types[-1]}"
            )
            raise BadProgram(msg)

    @property
    def steps(self) -> tuple[int, ...]:
        """Indices of the ``move`` nodes of the final chain, in execution order."""
        chain: list[int] = []
        i = len(self.nodes) - 1
        while self.nodes[i].op == "move":
            chain.append(i)
            i = self.nodes[i].inputs[0]
        return tuple(reversed(chain))

    def uses(self, node_index: int, op: str) -> bool:
        """Whether the subtree under ``node_index`` contains an ``op`` node."""
        node = self.nodes[node_index]
        return node.op == op or any(self.uses(i, op) for i in node.inputs)

    @property
    def dsl_version(self) -> str:
        """The oldest DSL version that has every operation of the program (an operation's
        ``since`` in ``signatures.json``; ``dsl-v1`` where none says)."""
        ops = load_signatures()["operations"]
        return newest_dsl_version(str(ops[n.op].get("since", "dsl-v1")) for n in self.nodes)

    @property
    def relational(self) -> bool:
        """Whether any step's references use a relation."""
        return any(n.op == "relate" for n in self.nodes)

    def text(self, node_index: int | None = None) -> str:
        """The program in functional text form, e.g. ``move[top](idle(), unique(...), ...)``."""
        i = len(self.nodes) - 1 if node_index is None else node_index
        node = self.nodes[i]
        args = [self.text(j) for j in node.inputs]
        params = f"[{','.join(node.params)}]" if node.params else ""
        return f"{node.op}{params}({', '.join(args)})"

    def to_list(self) -> list[dict[str, Any]]:
        """Plain JSON-able form."""
        return [n.to_dict() for n in self.nodes]

    @classmethod
    def from_list(cls, data: object) -> Program:
        """Inverse of :meth:`to_list`; type-checks."""
        if not isinstance(data, list):
            msg = f"a program must be a list of nodes, got {type(data).__name__}"
            raise BadProgram(msg)
        return cls(tuple(Node.from_dict(d) for d in data))


@dataclass(frozen=True)
class GroundedStep:
    """One executed step: ``action`` moves object ``subject`` relative to object ``reference``."""

    action: str
    subject: int
    reference: int

    def to_list(self) -> list[Any]:
        """JSON form ``[action, subject, reference]``."""
        return [self.action, self.subject, self.reference]

    @classmethod
    def from_list(cls, data: Iterable[str | int]) -> GroundedStep:
        """Inverse of :meth:`to_list`."""
        try:
            action, subject, reference = data
            step = cls(str(action), int(subject), int(reference))
        except (TypeError, ValueError) as exc:
            msg = f"a grounded step is [action, subject, reference], got {data!r}"
            raise BadProgram(msg) from exc
        if step.action not in ACTIONS:
            msg = f"grounded step action {step.action!r} is not one of {list(ACTIONS)}"
            raise BadProgram(msg)
        return step
