"""Instruction templates, noun-phrase forms and synonyms: loaded from the data files.

``templates/steps.json`` holds the step templates (each with several text variants and
the actions it fits), ``templates/phrases.json`` the noun-phrase forms per phrasing family
(simple / complex / compound), ``templates/synonyms.json`` the synonyms and connectors,
and ``templates/phenomena.json`` the phrasings of the semantics split's phenomena.
A subset of templates and synonyms is marked ``held_out``: it appears only in the
out-of-distribution language split.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.vocabulary import ACTIONS, PHENOMENA, PHRASINGS

__all__ = ["Language", "StepTemplate", "WordChoice", "load_language", "load_phenomena"]

_SLOT = re.compile(r"\{([a-z_:]+)\}")


@dataclass(frozen=True)
class StepTemplate:
    """One step template: text variants with slots, and the actions it can express."""

    id: str
    actions: tuple[str, ...]
    held_out: bool
    text: tuple[str, ...]


@dataclass(frozen=True)
class WordChoice:
    """The words a slot may take: in-distribution values and held-out ones."""

    values: tuple[str, ...]
    held_out: tuple[str, ...]


@dataclass(frozen=True)
class Language:
    """Everything instruction rendering reads from the data files."""

    steps: tuple[StepTemplate, ...]
    phrases: dict[str, Any]
    words: dict[str, WordChoice]
    connectors: WordChoice
    final_connectors: WordChoice
    pronoun_probability: float

    def templates_for(self, action: str, held_out: bool | None) -> tuple[StepTemplate, ...]:
        """Templates that can express ``action`` (held-out ones only / none / either)."""
        return tuple(
            t for t in self.steps
            if action in t.actions and (held_out is None or t.held_out == held_out)
        )

    def counts(self) -> dict[str, int]:
        """Counts of templates, text variants and synonyms (for reports)."""
        return {
            "step_templates": len(self.steps),
            "held_out_templates": sum(t.held_out for t in self.steps),
            "text_variants": sum(len(t.text) for t in self.steps),
            "synonym_slots": len(self.words),
            "synonyms": sum(len(w.values) for w in self.words.values()),
            "held_out_synonyms": sum(len(w.held_out) for w in self.words.values()),
            "connectors": len(self.connectors.values) + len(self.final_connectors.values),
        }


def _read(name: str) -> dict[str, Any]:
    text = (
        resources.files("nsrmp_bench.generators").joinpath("templates", name).read_text("utf-8")
    )
    data: dict[str, Any] = json.loads(text)
    return data


def _choice(data: dict[str, Any], where: str) -> WordChoice:
    values = tuple(str(v) for v in data.get("values", ()))
    if not values:
        msg = f"{where} needs at least one in-distribution value in 'values'"
        raise InvalidArgument(msg)
    return WordChoice(values, tuple(str(v) for v in data.get("held_out", ())))


@cache
def load_language() -> Language:
    """Load and validate the template and synonym files (cached)."""
    steps_data = _read("steps.json")
    phrases = _read("phrases.json")
    syn = _read("synonyms.json")
    words = {k: _choice(v, f"synonyms.json words.{k}") for k, v in syn["words"].items()}
    known_slots = {"subject", "reference", "action", "side", "put"}
    steps = []
    seen: set[str] = set()
    for raw in steps_data["steps"]:
        t = StepTemplate(str(raw["id"]), tuple(raw["actions"]), bool(raw["held_out"]),
                         tuple(raw["text"]))
        if t.id in seen:
            msg = f"steps.json: template id {t.id!r} appears twice; ids must be unique"
            raise InvalidArgument(msg)
        seen.add(t.id)
        bad = [a for a in t.actions if a not in ACTIONS]
        if bad:
            msg = f"steps.json {t.id}: unknown actions {bad}; expected {list(ACTIONS)}"
            raise InvalidArgument(msg)
        for variant in t.text:
            slots = set(_SLOT.findall(variant))
            if not {"subject", "reference"} <= slots or slots - known_slots:
                msg = (
                    f"steps.json {t.id}: variant {variant!r} must use {{subject}} and "
                    f"{{reference}} and only the slots {sorted(known_slots)}"
                )
                raise InvalidArgument(msg)
            if "side" in slots and set(t.actions) - {"left", "right"}:
                msg = f"steps.json {t.id}: {{side}} only fits left/right templates"
                raise InvalidArgument(msg)
        steps.append(t)
    for fam in PHRASINGS:
        if fam not in phrases["attribute"] or fam not in phrases["relational"]:
            msg = f"phrases.json lacks the phrasing family {fam!r}"
            raise InvalidArgument(msg)
    return Language(
        steps=tuple(steps),
        phrases=phrases,
        words=words,
        connectors=_choice(syn["connectors"], "synonyms.json connectors"),
        final_connectors=_choice(syn["final_connectors"], "synonyms.json final_connectors"),
        pronoun_probability=float(syn["pronoun_probability"]),
    )


@cache
def load_phenomena() -> dict[str, Any]:
    """The phenomena phrasings (``templates/phenomena.json``), checked and cached.

    Every phenomenon with phrasings has a ``seen`` and a ``held_out`` entry; the seen
    and held-out phrasings never share a text.
    """
    data = _read("phenomena.json")
    for name in PHENOMENA:
        if name == "ambiguous":  # its phrasing is the reference form, chosen in code
            continue
        entry = data.get(name)
        if not isinstance(entry, dict) or not {"seen", "held_out"} <= set(entry):
            msg = (f"phenomena.json: {name!r} needs 'seen' and 'held_out' phrasings; "
                   "add both to generators/templates/phenomena.json")
            raise InvalidArgument(msg)
        if isinstance(entry["seen"], list) and set(entry["seen"]) & set(entry["held_out"]):
            msg = f"phenomena.json: {name!r} has a phrasing both seen and held out"
            raise InvalidArgument(msg)
    return data
