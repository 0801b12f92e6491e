"""Instructions whose meaning is more than their words: the semantics split's phenomena.

Each phenomenon of :data:`~nsrmp_bench.vocabulary.PHENOMENA` has one writer here. A writer
reads the scene, the episode's config and its Generator, and returns the gold program (with
its grounding, states and reference labels), the instruction, and the gold decision
(``abstain``: "" when the instruction is to be carried out):

* ``negation``: an ordinary instruction with a constraint on an object it does not use
  ("..., and leave the green lego where it is"): the same program; that object stays.
* ``prohibition``: "Don't move the red lego.": no step, ``no action``.
* ``question``: a question about the scene or a remark ("Is the red lego behind the white
  dice?", "The cube is left of the dice."): no step, ``no action``.
* ``absent``: an instruction naming an object the scene lacks (a colour or shape outside
  the world, or a colour-shape pair no object has): no step, ``not feasible``.
* ``ambiguous``: a reference that two or more objects fit, nothing telling them apart:
  no step, ``not feasible``.
* ``two_sentence``: one pick-and-place in two sentences ("Pick up X. Put it on Y."): one
  step.
* ``ellipsis``: a second step that leaves its verb and shape out and refers back ("...,
  then the green one on top of it"): two steps.
* ``correction``: a self-correction ("on the blue cube, no, on the green one"): the
  corrected step.
* ``superlative``: a superlative or ordinal ("the leftmost cube", "the second dice from
  the right"): the DSL's ``extreme`` operation.

Phrasings are data (``templates/phenomena.json``): ``seen`` ones for every part and
``held_out`` ones for the test part only (``config.phenomenon_phrasing``). A writer that
cannot write its phenomenon on a scene raises :class:`GenerationError`, and the sampler
moves on to the next attempt's seed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.dsl.actions import apply_step, step_problem
from nsrmp_bench.dsl.executor import execute
from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.dsl.relations import related
from nsrmp_bench.episode import Instruction, ReferenceLabel
from nsrmp_bench.errors import GenerationError, NSRMPError
from nsrmp_bench.generators.instructions import PhraseWriter, render_instruction
from nsrmp_bench.generators.program_sampler import ProgramSample, sample_program
from nsrmp_bench.generators.references import (
    Reference,
    attribute_references,
    compile_reference,
    superlative_references,
)
from nsrmp_bench.generators.templates import load_language, load_phenomena
from nsrmp_bench.scene import Scene
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, RELATIONS, SHAPES

__all__ = ["PhenomenonSample", "write_phenomenon"]


@dataclass(frozen=True)
class PhenomenonSample:
    """What a phenomenon writer gives: the gold program, the instruction, the decision."""

    sample: ProgramSample
    instruction: Instruction
    abstain: str = ""


@dataclass
class _Context:
    rng: np.random.Generator
    config: EpisodeConfig
    scene: Scene

    @property
    def held_out(self) -> bool:
        return self.config.phenomenon_phrasing == "held_out"

    def writer(self) -> PhraseWriter:
        return PhraseWriter(self.rng, load_language(), self.config.phrasing, "exclude",
                            phenomenon_phrasing=self.config.phenomenon_phrasing)

    def choose(self, items: Sequence[Any]) -> Any:
        if not items:
            msg = f"{self.config.phenomenon}: nothing to choose from on this scene"
            raise GenerationError(msg)
        return items[int(self.rng.integers(0, len(items)))]

    def phrasing(self, name: str) -> tuple[str, str]:
        """A phrasing of ``name`` from the config's set, and its id (``name/s2``)."""
        kind = self.config.phenomenon_phrasing
        texts: list[str] = load_phenomena()[name][kind]
        k = int(self.rng.integers(0, len(texts)))
        return texts[k], f"{name}/{'h' if kind == 'held_out' else 's'}{k}"

    def base(self, steps: int | None = None) -> ProgramSample:
        return sample_program(self.rng, self.scene, steps or self.config.steps,
                              relational=self.config.relational)

    def render(self, sample: ProgramSample) -> Instruction:
        return render_instruction(
            self.rng, load_language(), self.scene.objects, sample,
            phrasing=self.config.phrasing, phenomenon_phrasing=self.config.phenomenon_phrasing,
        )

    def instruction(self, text: str, template_id: str, base: Instruction | None = None
                    ) -> Instruction:
        ids = template_id if base is None else f"{template_id}+{base.template_id}"
        return Instruction(text=_capitalise(text), template_id=ids,
                           phrasing=self.config.phrasing, held_out_template=self.held_out)

    def named(self, index: int) -> Reference:
        """An attribute reference that names object ``index`` alone."""
        refs = attribute_references(self.scene.objects, index)
        if not refs:
            msg = f"object {index} has no attribute reference of its own"
            raise GenerationError(msg)
        return self.choose(refs)  # type: ignore[no-any-return]


def _capitalise(text: str) -> str:
    return text[:1].upper() + text[1:]


def _clause(instruction: Instruction) -> str:
    """An instruction's text without its full stop."""
    return instruction.text[:-1] if instruction.text.endswith(".") else instruction.text


def _fill(text: str, **values: str) -> str:
    for key, value in values.items():
        text = text.replace("{" + key + "}", value)
    if "{" in text or "}" in text:
        msg = f"a phenomena phrasing kept an unfilled slot: {text!r}; check phenomena.json"
        raise GenerationError(msg)
    return text


def _empty(scene: Scene) -> ProgramSample:
    return ProgramSample(Program((Node("idle"),)), (), (scene.initial,), (), ())


def _program(ctx: _Context, grounded: Sequence[GroundedStep],
             references: Sequence[tuple[Reference, Reference]]) -> ProgramSample:
    """The program naming each step's objects by ``references``, executed as a check."""
    nodes: list[Node] = [Node("idle")]
    chain = 0
    for step, (ref_s, ref_r) in zip(grounded, references, strict=True):
        si = compile_reference(ref_s, nodes)
        ri = compile_reference(ref_r, nodes)
        nodes.append(Node("move", (chain, si, ri), (step.action,)))
        chain = len(nodes) - 1
    program = Program(tuple(nodes))
    try:
        run = execute(program, ctx.scene)
    except NSRMPError as exc:
        msg = f"the rewritten program does not run on the scene: {exc}"
        raise GenerationError(msg) from exc
    if run.grounded != tuple(grounded):
        msg = "the rewritten references ground other objects than the sampled steps"
        raise GenerationError(msg)
    labels = tuple(
        ReferenceLabel(k, role, ref.relational, False)
        for k, pair in enumerate(references) for role, ref in zip(("subject", "reference"), pair,
                                                                 strict=True)
    )
    return ProgramSample(program, tuple(grounded), run.states, tuple(references), labels)


def _then(ctx: _Context, sample: ProgramSample) -> str:
    """The steps after the first, written as a following sentence (or "")."""
    if len(sample.grounded) < 2:
        return ""
    rest = replace(sample, grounded=sample.grounded[1:], references=sample.references[1:])
    text = ctx.render(rest).text
    return " Then " + text[:1].lower() + text[1:]


# -- the writers ------------------------------------------------------------------------


def _negation(ctx: _Context) -> PhenomenonSample:
    sample = ctx.base()
    used = {i for s in sample.grounded for i in (s.subject, s.reference)}
    free = [i for i in range(len(ctx.scene.objects))
            if i not in used and attribute_references(ctx.scene.objects, i)]
    x = ctx.writer().noun_phrase(ctx.named(ctx.choose(free)))
    base = ctx.render(sample)
    text, tid = ctx.phrasing("negation")
    return PhenomenonSample(sample, ctx.instruction(_fill(text, clause=_clause(base), x=x),
                                                    tid, base))


def _prohibition(ctx: _Context) -> PhenomenonSample:
    w = ctx.writer()
    x = w.noun_phrase(ctx.named(int(ctx.rng.integers(0, len(ctx.scene.objects)))))
    text, tid = ctx.phrasing("prohibition")
    return PhenomenonSample(_empty(ctx.scene),
                            ctx.instruction(_fill(text, x=x, X=_capitalise(x),
                                                  put=w.slot("put")), tid),
                            "no action")


def _question(ctx: _Context) -> PhenomenonSample:
    objects, state = ctx.scene.objects, ctx.scene.initial
    true_pairs = [(x, y, rel) for y in range(len(objects)) for rel in RELATIONS
                  for x in sorted(related(state, y, rel))
                  if attribute_references(objects, x) and attribute_references(objects, y)]
    x, y, rel = ctx.choose(true_pairs)
    w = ctx.writer()
    nx, ny = w.noun_phrase(ctx.named(x)), w.noun_phrase(ctx.named(y))
    text, tid = ctx.phrasing("question")
    text = _fill(text, x=nx, X=_capitalise(nx), y=ny, relation=w.slot(f"relation:{rel}"))
    return PhenomenonSample(_empty(ctx.scene), ctx.instruction(text, tid), "no action")


def _absent_reference(ctx: _Context, target: int) -> tuple[Reference, str]:
    """A description of an object the scene lacks, in the place of ``target``'s."""
    objects = ctx.scene.objects
    words = load_phenomena()["absent"][ctx.config.phenomenon_phrasing]
    kind = ctx.choose(("colour", "shape", "pair"))
    if kind == "colour":
        return Reference(ctx.choose(words["colours"]), objects[target].shape), kind
    if kind == "shape":
        return Reference(objects[target].colour, ctx.choose(words["shapes"])), kind
    present = {(o.colour, o.shape) for o in objects}
    pairs = [(c, s) for s in SHAPES for c in COLOURS
             if (c, s) not in present and s == objects[target].shape]
    colour, shape = ctx.choose(pairs)
    return Reference(colour, shape), kind


def _replace_first(sample: ProgramSample, role: int, ref: Reference) -> ProgramSample:
    first = list(sample.references[0])
    first[role] = ref
    return replace(sample, references=(tuple(first), *sample.references[1:]))  # type: ignore[arg-type]


def _absent(ctx: _Context) -> PhenomenonSample:
    sample = ctx.base()
    role = int(ctx.rng.integers(0, 2))
    step = sample.grounded[0]
    ref, kind = _absent_reference(ctx, step.subject if role == 0 else step.reference)
    base = ctx.render(_replace_first(sample, role, ref))
    return PhenomenonSample(_empty(ctx.scene),
                            ctx.instruction(base.text, f"absent/{kind}", base), "not feasible")


def _ambiguous(ctx: _Context) -> PhenomenonSample:
    objects = ctx.scene.objects
    if ctx.held_out:  # a colour alone or a shape alone that several objects have
        options = [Reference(c, None) for c in COLOURS
                   if sum(o.colour == c for o in objects) >= 2]
        options += [Reference(None, s) for s in SHAPES
                    if sum(o.shape == s for o in objects) >= 2]
        kind = "underspecified"
    else:  # two objects of the same colour and shape
        options = [Reference(c, s) for s in SHAPES for c in COLOURS
                   if sum((o.colour, o.shape) == (c, s) for o in objects) >= 2]
        kind = "duplicate"
    ref = ctx.choose(options)
    fits = [i for i, o in enumerate(objects)
            if ref.colour in (None, o.colour) and ref.shape in (None, o.shape)]
    others = [i for i in range(len(objects))
              if i not in fits and attribute_references(objects, i)]
    other = ctx.choose(others)
    action = ctx.choose(ACTIONS)
    # a one-step sentence around the ambiguous reference (its program is never run)
    if ctx.rng.random() < 0.5:
        step, refs = GroundedStep(action, fits[0], other), (ref, ctx.named(other))
    else:
        step, refs = GroundedStep(action, other, fits[0]), (ctx.named(other), ref)
    written = replace(_empty(ctx.scene), grounded=(step,), references=(refs,))
    base = ctx.render(written)
    return PhenomenonSample(_empty(ctx.scene),
                            ctx.instruction(base.text, f"ambiguous/{kind}", base),
                            "not feasible")


def _two_sentence(ctx: _Context) -> PhenomenonSample:
    sample = ctx.base()
    step = sample.grounded[0]
    ref_s, ref_r = sample.references[0]
    w = ctx.writer()
    text, tid = ctx.phrasing("two_sentence")
    text = _fill(text, subject=w.noun_phrase(ref_s), reference=w.noun_phrase(ref_r),
                 Put=_capitalise(w.slot("put")), put=w.slot("put"),
                 action=w.slot(f"action:{step.action}"))
    return PhenomenonSample(sample, ctx.instruction(text + _then(ctx, sample), tid))


def _ellipsis(ctx: _Context) -> PhenomenonSample:
    first = ctx.base(1)
    objects = ctx.scene.objects
    s1 = first.grounded[0].subject
    shape = objects[s1].shape
    state = first.states[-1]
    candidates = [i for i, o in enumerate(objects)
                  if i != s1 and o.shape == shape and o.colour != objects[s1].colour
                  and sum(p.colour == o.colour for p in objects) == 1]
    steps = [GroundedStep(a, s2, s1) for s2 in candidates for a in ACTIONS]
    steps = [s for s in steps if step_problem(objects, state, s) is None]
    second = ctx.choose(steps)
    references = (first.references[0], (Reference(objects[second.subject].colour, shape),
                                        ctx.named(s1)))
    sample = _program(ctx, (first.grounded[0], second), references)
    if sample.states[-1] != apply_step(objects, state, second):  # pragma: no cover - defensive
        msg = "the second step's state differs from the executed program's"
        raise GenerationError(msg)
    w = ctx.writer()
    text, tid = ctx.phrasing("ellipsis")
    base = ctx.render(first)
    text = _fill(text, clause=_clause(base), colour=objects[second.subject].colour,
                 action=w.slot(f"action:{second.action}"))
    return PhenomenonSample(sample, ctx.instruction(text, tid, base))


def _correction(ctx: _Context) -> PhenomenonSample:
    sample = ctx.base()
    objects = ctx.scene.objects
    step = sample.grounded[0]
    ref_s, ref_r = sample.references[0]
    wrong = [i for i in range(len(objects))
             if i not in (step.subject, step.reference) and attribute_references(objects, i)]
    same_shape = [i for i in wrong if objects[i].shape == objects[step.reference].shape]
    w_index = ctx.choose(same_shape or wrong)
    w = ctx.writer()
    right = w.noun_phrase(ref_r)
    if (objects[w_index].shape == objects[step.reference].shape
            and ref_r == Reference(objects[step.reference].colour, objects[step.reference].shape)
            and ctx.rng.random() < 0.5):
        right = f"the {objects[step.reference].colour} one"
    text, tid = ctx.phrasing("correction")
    action = w.slot(f"action:{step.action}")
    text = _fill(text, put=w.slot("put"), subject=w.noun_phrase(ref_s), action=action,
                 wrong=w.noun_phrase(ctx.named(w_index)), right=right)
    return PhenomenonSample(sample, ctx.instruction(text + "." + _then(ctx, sample), tid))


def _superlative(ctx: _Context) -> PhenomenonSample:
    sample = ctx.base()
    step = sample.grounded[0]
    options = [(role, ref) for role, target in enumerate((step.subject, step.reference))
               for ref in superlative_references(ctx.scene.objects, ctx.scene.initial, target)]
    role, ref = ctx.choose(options)
    first = list(sample.references[0])
    first[role] = ref
    references = (tuple(first), *sample.references[1:])
    rewritten = _program(ctx, sample.grounded, references)  # type: ignore[arg-type]
    base = ctx.render(rewritten)
    return PhenomenonSample(rewritten, ctx.instruction(base.text, "superlative", base))


_WRITERS: dict[str, Callable[[_Context], PhenomenonSample]] = {
    "negation": _negation,
    "prohibition": _prohibition,
    "question": _question,
    "absent": _absent,
    "ambiguous": _ambiguous,
    "two_sentence": _two_sentence,
    "ellipsis": _ellipsis,
    "correction": _correction,
    "superlative": _superlative,
}
"""Phenomenon -> writer; keys equal ``vocabulary.PHENOMENA`` (a test checks)."""


def write_phenomenon(rng: np.random.Generator, config: EpisodeConfig, scene: Scene
                     ) -> PhenomenonSample:
    """The gold program, instruction and decision of ``config.phenomenon`` on ``scene``."""
    writer = _WRITERS.get(config.phenomenon)
    if writer is None:
        msg = f"phenomenon {config.phenomenon!r} has no writer; expected one of {list(_WRITERS)}"
        raise GenerationError(msg)
    return writer(_Context(rng, config, scene))
