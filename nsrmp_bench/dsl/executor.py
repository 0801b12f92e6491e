"""The symbolic executor: runs a program on a scene through a dispatch table.

Each operation of ``signatures.json`` has one handler in :data:`HANDLERS` (a test checks
the keys match). Handlers are pure: they read the scene and a state and return a value;
nothing is mutated. A ``move`` first evaluates the chain before it, then resolves its two
object references on the state *after* that chain (sequential semantics), then applies the
step. ``unique`` raises :class:`InvalidReference` / :class:`AmbiguousReference` rather than
returning a sentinel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from nsrmp_bench.dsl.actions import apply_step
from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.dsl.relations import ranked, related
from nsrmp_bench.errors import AmbiguousReference, InfeasibleStep, InvalidReference
from nsrmp_bench.scene import Scene, State

__all__ = ["HANDLERS", "Execution", "execute", "execute_grounded", "resolve"]


@dataclass(frozen=True)
class Execution:
    """The result of running a program: every state and the grounded steps."""

    states: tuple[State, ...]
    grounded: tuple[GroundedStep, ...]

    @property
    def final(self) -> State:
        """The state after the last step."""
        return self.states[-1]


class _Context:
    """What handlers see: the program, the objects, and an evaluator for other nodes."""

    def __init__(self, program: Program, scene: Scene):
        self.program = program
        self.objects = scene.objects
        self.initial = scene.initial
        self.workspace = scene.workspace
        self._memo: dict[tuple[int, int], Any] = {}
        self.step = 0

    def eval(self, index: int, state: State) -> Any:
        key = (index, id(state))
        if key not in self._memo:
            node = self.program.nodes[index]
            self._memo[key] = HANDLERS[node.op](self, node, index, state)
        return self._memo[key]


Handler = Callable[[_Context, Node, int, State], Any]


def _scene(ctx: _Context, node: Node, index: int, state: State) -> frozenset[int]:
    return frozenset(range(len(ctx.objects)))


def _filter(ctx: _Context, node: Node, index: int, state: State) -> frozenset[int]:
    concept = node.params[0]
    members: frozenset[int] = ctx.eval(node.inputs[0], state)
    return frozenset(
        i for i in members if concept in (ctx.objects[i].colour, ctx.objects[i].shape)
    )


def _relate(ctx: _Context, node: Node, index: int, state: State) -> frozenset[int]:
    anchor: int = ctx.eval(node.inputs[0], state)
    return related(state, anchor, node.params[0])


def _unique(ctx: _Context, node: Node, index: int, state: State) -> int:
    members: frozenset[int] = ctx.eval(node.inputs[0], state)
    if len(members) == 1:
        return next(iter(members))
    where = f"step {ctx.step + 1}, node {index}: {ctx.program.text(node.inputs[0])}"
    if not members:
        msg = (
            f"{where} matches no object in the state before that step; the reference is "
            "invalid here: check its concepts and relation against the scene"
        )
        raise InvalidReference(msg)
    labels = ", ".join(f"{i} ({ctx.objects[i].label})" for i in sorted(members))
    msg = (
        f"{where} matches {len(members)} objects ({labels}) in the state before that step; "
        "add an attribute or a relation to make the reference unique"
    )
    raise AmbiguousReference(msg)


def _extreme(ctx: _Context, node: Node, index: int, state: State) -> int:
    members: frozenset[int] = ctx.eval(node.inputs[0], state)
    try:
        return ranked(state, members, node.params[0], int(node.params[1]))
    except (InvalidReference, AmbiguousReference) as exc:
        where = f"step {ctx.step + 1}, node {index}: {ctx.program.text(index)}"
        msg = (f"{where}: {exc}; name the object by its attributes or a relation instead")
        raise type(exc)(msg) from exc


def _idle(ctx: _Context, node: Node, index: int, state: State) -> Execution:
    return Execution((ctx.initial,), ())


def _move(ctx: _Context, node: Node, index: int, state: State) -> Execution:
    chain: Execution = ctx.eval(node.inputs[0], state)
    current = chain.final
    ctx.step = len(chain.grounded)
    subject: int = ctx.eval(node.inputs[1], current)
    reference: int = ctx.eval(node.inputs[2], current)
    step = GroundedStep(node.params[0], subject, reference)
    try:
        after = apply_step(ctx.objects, current, step, ctx.workspace)
    except InfeasibleStep as exc:
        msg = f"step {ctx.step + 1}: {exc}"
        raise InfeasibleStep(msg) from exc
    return Execution((*chain.states, after), (*chain.grounded, step))


HANDLERS: dict[str, Handler] = {
    "scene": _scene,
    "filter": _filter,
    "relate": _relate,
    "unique": _unique,
    "extreme": _extreme,
    "idle": _idle,
    "move": _move,
}
"""Operation name -> handler; keys equal the operations of ``signatures.json``."""


def execute(program: Program, scene: Scene) -> Execution:
    """Run ``program`` on ``scene`` from its initial state."""
    ctx = _Context(program, scene)
    result: Execution = ctx.eval(len(program.nodes) - 1, scene.initial)
    return result


def resolve(program: Program, node_index: int, scene: Scene, state: State) -> Any:
    """Evaluate one node of ``program`` (e.g. a reference's ``unique``) on ``state``."""
    return _Context(program, scene).eval(node_index, state)


def execute_grounded(scene: Scene, steps: Sequence[GroundedStep]) -> Execution:
    """Apply already-grounded steps to ``scene``'s initial state, checking each one."""
    states = [scene.initial]
    for k, step in enumerate(steps):
        try:
            states.append(apply_step(scene.objects, states[-1], step, scene.workspace))
        except InfeasibleStep as exc:
            msg = f"step {k + 1}: {exc}"
            raise InfeasibleStep(msg) from exc
    return Execution(tuple(states), tuple(steps))
