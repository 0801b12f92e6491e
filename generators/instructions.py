"""Rendering a sampled program as a natural-language instruction.

Each step is written with a step template that fits its action (one of several text
variants), its two objects as noun phrases of the episode's phrasing family, and synonyms
for verbs, shapes, actions, relations and "which/that". Steps are chained with varied
connectors. A later step may call the previous step's moved object "it". Held-out
templates and synonyms are used only when ``held_out`` asks for them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nsrmp_bench.config import HELD_OUT_MODES
from nsrmp_bench.episode import Instruction
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.generators.program_sampler import ProgramSample
from nsrmp_bench.generators.references import Reference
from nsrmp_bench.generators.templates import (
    Language,
    StepTemplate,
    WordChoice,
    load_phenomena,
)
from nsrmp_bench.scene import SceneObject
from nsrmp_bench.vocabulary import PHRASINGS, SHAPES

__all__ = ["HELD_OUT_MODES", "PhraseWriter", "render_instruction"]

_HELD_OUT_P = 0.5


@dataclass
class PhraseWriter:
    """Draws words, noun phrases and templates for one instruction from ``rng``."""

    rng: np.random.Generator
    language: Language
    family: str
    held_out: str
    used_templates: list[str] = field(default_factory=list)
    used_held_out: list[str] = field(default_factory=list)
    held_out_template: bool = False
    phenomenon_phrasing: str = "seen"
    """Which phrasings of ``phenomena.json`` superlatives take: seen or held_out."""

    def word(self, choice: WordChoice) -> str:
        if self.held_out == "require" and choice.held_out and self.rng.random() < _HELD_OUT_P:
            w = choice.held_out[int(self.rng.integers(0, len(choice.held_out)))]
            self.used_held_out.append(w)
            return w
        return choice.values[int(self.rng.integers(0, len(choice.values)))]

    def slot(self, key: str) -> str:
        return self.word(self.language.words[key])

    def pick(self, options: list[str] | tuple[str, ...]) -> str:
        return options[int(self.rng.integers(0, len(options)))]

    def fill(self, text: str, **values: str) -> str:
        """Fill the lexical slots of ``text`` (block, which, colour_word) and the given ones."""
        for key in ("block", "which", "colour_word"):
            while "{" + key + "}" in text:
                text = text.replace("{" + key + "}", self.slot(key), 1)
        for key, value in values.items():
            text = text.replace("{" + key + "}", value)
        return text

    def noun_phrase(self, ref: Reference) -> str:
        phrases = self.language.phrases
        # a shape outside the world (an absent referent) is written as it is
        shape = (self.slot(f"shape:{ref.shape}") if ref.shape in SHAPES else ref.shape or "")
        colour = ref.colour or ""
        if ref.extreme is not None:
            forms = load_phenomena()["superlative"][self.phenomenon_phrasing]
            noun = self.fill(phrases["head"][ref.form], colour=colour, shape=shape)
            form = self.pick(forms[ref.extreme][str(ref.rank)])
            return self.fill(form, noun=noun)
        if ref.relation is None or ref.anchor is None:
            form = self.pick(phrases["attribute"][self.family][ref.form])
            return self.fill(form, colour=colour, shape=shape)
        head = self.fill(phrases["head"][ref.form], colour=colour, shape=shape)
        form = self.pick(phrases["relational"][self.family])
        relation = self.slot(f"relation:{ref.relation}")
        anchor = self.noun_phrase(ref.anchor)
        return self.fill(form, head=head, relation=relation, anchor=anchor)

    def template(self, action: str) -> StepTemplate:
        pool = self.language.templates_for(action, held_out=False)
        if self.held_out == "require" and self.rng.random() < _HELD_OUT_P:
            held = self.language.templates_for(action, held_out=True)
            if held:
                pool = held
                self.held_out_template = True
        return pool[int(self.rng.integers(0, len(pool)))]


def _capitalise(text: str) -> str:
    return text[:1].upper() + text[1:]


def render_instruction(
    rng: np.random.Generator,
    language: Language,
    objects: tuple[SceneObject, ...],
    sample: ProgramSample,
    *,
    phrasing: str,
    held_out: str = "exclude",
    max_tries: int = 32,
    phenomenon_phrasing: str = "seen",
) -> Instruction:
    """Write ``sample`` as an instruction in the ``phrasing`` family (superlative
    references in the ``phenomenon_phrasing`` phrasings: seen or held_out)."""
    if phrasing not in PHRASINGS:
        msg = f"phrasing={phrasing!r}; expected one of {list(PHRASINGS)}"
        raise InvalidArgument(msg)
    if held_out not in HELD_OUT_MODES:
        msg = f"held_out={held_out!r}; expected one of {list(HELD_OUT_MODES)}"
        raise InvalidArgument(msg)
    for _ in range(max_tries):
        w = PhraseWriter(rng, language, phrasing, held_out, phenomenon_phrasing=phenomenon_phrasing)
        clauses: list[str] = []
        lexed: list[str] = []
        ids: list[str] = []
        for k, (step, (ref_s, ref_r)) in enumerate(
            zip(sample.grounded, sample.references, strict=True)
        ):
            tpl = w.template(step.action)
            ids.append(tpl.id)
            variant = w.pick(tpl.text)
            subject = w.noun_phrase(ref_s)
            reference = w.noun_phrase(ref_r)
            if (
                k > 0
                and step.reference == sample.grounded[k - 1].subject
                and variant.endswith("{reference}")
                and rng.random() < language.pronoun_probability
            ):
                reference = "it"
            values = {"put": w.slot("put"), "side": step.action}
            if "{action}" in variant:
                values["action"] = w.slot(f"action:{step.action}")
            clause = w.fill(variant, subject=subject, reference=reference, **values)
            lex = w.fill(variant, subject=f"<S{k + 1}>", reference=f"<R{k + 1}>", **values)
            if k > 0:
                last = k == len(sample.grounded) - 1 and k >= 2 and rng.random() < 0.5
                conn = w.word(language.final_connectors if last else language.connectors)
                clause, lex = f"{conn} {clause}", f"{conn} {lex}"
            clauses.append(clause)
            lexed.append(lex)
        if held_out == "require" and not (w.held_out_template or w.used_held_out):
            continue
        text = _capitalise("".join(clauses)) + "."
        if "{" in text or "}" in text:
            msg = f"an instruction kept an unfilled slot: {text!r}; check the template files"
            raise GenerationError(msg)
        return Instruction(
            text=text,
            template_id="+".join(ids),
            phrasing=phrasing,
            lexed=_capitalise("".join(lexed)) + ".",
            held_out_template=w.held_out_template,
            held_out_synonyms=tuple(sorted(set(w.used_held_out))),
        )
    msg = f"could not use a held-out template or synonym in {max_tries} tries"
    raise GenerationError(msg)
