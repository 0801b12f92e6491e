"""Sampling a grounded program and its references on a scene.

For each step, candidate steps (action, subject, reference) are drawn in random order and
checked with the named step checks of :mod:`nsrmp_bench.dsl.actions`; a step is kept when
both its objects can be named as the episode's policy asks (attribute-only, or through a
relation; a relation *needed* to disambiguate or *redundant*). Every rejected candidate's
reason is counted. References are resolved on the state before their step.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from nsrmp_bench.config import RELATIONAL_POLICIES
from nsrmp_bench.dsl.actions import apply_step, step_problem
from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.episode import ReferenceLabel
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.generators.references import (
    Reference,
    attribute_references,
    compile_reference,
    relational_references,
)
from nsrmp_bench.scene import Scene, State
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["RELATIONAL_POLICIES", "ProgramSample", "sample_program"]


_OPTIONAL_RELATIONAL_P = 0.25


@dataclass(frozen=True)
class ProgramSample:
    """A sampled program with its grounding, states and reference descriptions."""

    program: Program
    grounded: tuple[GroundedStep, ...]
    states: tuple[State, ...]
    references: tuple[tuple[Reference, Reference], ...]
    labels: tuple[ReferenceLabel, ...]
    rejections: Counter[str] = field(default_factory=Counter)


def _pick(rng: np.random.Generator, items: list[Reference]) -> Reference:
    return items[int(rng.integers(0, len(items)))]


def _name(
    rng: np.random.Generator,
    scene: Scene,
    state: State,
    target: int,
    want: str,
) -> tuple[Reference, bool] | None:
    """A reference for ``target``: want is attr, rel-needed, rel-redundant, rel-any or free."""
    attrs = attribute_references(scene.objects, target)
    if want == "attr":
        return (_pick(rng, attrs), False) if attrs else None
    needed = not attrs
    if want == "free":
        if attrs and rng.random() >= _OPTIONAL_RELATIONAL_P:
            return _pick(rng, attrs), False
        rels = relational_references(scene.objects, state, target)
        if rels:
            return _pick(rng, rels), needed
        return (_pick(rng, attrs), False) if attrs else None
    if (want == "rel-needed" and not needed) or (want == "rel-redundant" and needed):
        return None
    rels = relational_references(scene.objects, state, target)
    return (_pick(rng, rels), needed) if rels else None


def sample_program(
    rng: np.random.Generator,
    scene: Scene,
    n_steps: int,
    *,
    relational: str = "any",
    max_candidates: int = 4000,
) -> ProgramSample:
    """Sample an ``n_steps``-step program on ``scene`` following the ``relational`` policy."""
    if relational not in RELATIONAL_POLICIES:
        msg = f"relational={relational!r}; expected one of {list(RELATIONAL_POLICIES)}"
        raise InvalidArgument(msg)
    if not 1 <= n_steps <= 7:
        msg = f"n_steps={n_steps} is out of range; expected 1..7"
        raise InvalidArgument(msg)
    # Which reference must carry the relation: (step, role) drawn up front.
    forced = (int(rng.integers(0, n_steps)), int(rng.integers(0, 2)))
    objects = scene.objects
    n = len(objects)
    nodes: list[Node] = [Node("idle")]
    chain = 0
    states: list[State] = [scene.initial]
    grounded: list[GroundedStep] = []
    refs: list[tuple[Reference, Reference]] = []
    labels: list[ReferenceLabel] = []
    rejections: Counter[str] = Counter()
    tried = 0
    for k in range(n_steps):
        state = states[-1]
        wants = ["attr", "attr"]
        if relational != "none":
            wants = ["free", "free"]
            if k == forced[0]:
                wants[forced[1]] = {
                    "any": "rel-any", "needed": "rel-needed", "redundant": "rel-redundant"
                }[relational]
            if relational == "redundant":
                wants = [w if w != "free" else "attr" for w in wants]
        order = rng.permutation(len(ACTIONS) * n * n)
        found = None
        for flat in order:
            tried += 1
            if tried > max_candidates:
                break
            a, rest = divmod(int(flat), n * n)
            s, r = divmod(rest, n)
            step = GroundedStep(ACTIONS[a], s, r)
            reason = "self_move" if s == r else step_problem(objects, state, step)
            if reason is not None:
                rejections[reason] += 1
                continue
            named_s = _name(rng, scene, state, s, wants[0])
            named_r = _name(rng, scene, state, r, wants[1]) if named_s else None
            if named_s is None or named_r is None:
                rejections["unnameable"] += 1
                continue
            found = (step, named_s, named_r)
            break
        if found is None:
            msg = (
                f"no step {k + 1} of {n_steps} satisfies the checks and the "
                f"relational={relational!r} policy on this scene ({n} objects) within "
                f"{max_candidates} candidates; the caller resamples from the next seed"
            )
            raise GenerationError(msg)
        step, (ref_s, need_s), (ref_r, need_r) = found
        si = compile_reference(ref_s, nodes)
        ri = compile_reference(ref_r, nodes)
        nodes.append(Node("move", (chain, si, ri), (step.action,)))
        chain = len(nodes) - 1
        grounded.append(step)
        states.append(apply_step(objects, state, step))
        refs.append((ref_s, ref_r))
        labels.append(ReferenceLabel(k, "subject", ref_s.relational, need_s))
        labels.append(ReferenceLabel(k, "reference", ref_r.relational, need_r))
    return ProgramSample(
        program=Program(tuple(nodes)),
        grounded=tuple(grounded),
        states=tuple(states),
        references=tuple(refs),
        labels=tuple(labels),
        rejections=rejections,
    )
