"""Audit of the splits: what is shared between parts, and where held-out material appears.

The audit reads symbolic episodes (from generated data, or regenerated from the specs) and
measures, across every part of every split given:

* seeds, ids, scenes and (scene, program, instruction) triples that occur in two parts
  (must be 0, else the audit fails);
* instruction texts that occur in two parts (reported; short instructions can coincide);
* held-out (shape, colour) combinations in parts that must not show them, and instances of
  parts that must use them but do not (must be 0);
* held-out templates or synonyms in parts that exclude them, and instructions of parts
  that require them without any (must be 0).
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from nsrmp_bench.canonical import content_hash
from nsrmp_bench.episode import SymbolicEpisode
from nsrmp_bench.split_specs import load_split

__all__ = ["AuditReport", "audit"]


class HeldOutWords(Protocol):
    """A slot's words as the generators' template language holds them."""

    @property
    def held_out(self) -> Iterable[str]: ...


class TemplateLanguage(Protocol):
    """What the audit reads of the generators' ``load_language()``."""

    @property
    def words(self) -> Mapping[str, HeldOutWords]: ...

    @property
    def connectors(self) -> HeldOutWords: ...

    @property
    def final_connectors(self) -> HeldOutWords: ...


@dataclass
class AuditReport:
    """Measured numbers; ``failures`` lists the ones that break a guarantee."""

    parts: dict[str, int] = field(default_factory=dict)
    shared: dict[str, int] = field(default_factory=dict)
    held_out: dict[str, int] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether every guarantee holds."""
        return not self.failures

    def rows(self) -> list[tuple[str, str, str]]:
        """(section, measure, value) rows for printing."""
        out = [("episodes", k, str(v)) for k, v in self.parts.items()]
        out += [("shared across parts", k, str(v)) for k, v in self.shared.items()]
        out += [("held-out material", k, str(v)) for k, v in self.held_out.items()]
        return out


def held_out_words(language: TemplateLanguage) -> set[str]:
    """The held-out words and connectors of a template language (the generators'
    ``load_language()``; the caller passes it, as the core never imports the generators)."""
    words = {w for c in language.words.values() for w in c.held_out}
    words |= {w.strip(" .,").lower() for w in language.connectors.held_out}
    words |= {w.strip(" .,").lower() for w in language.final_connectors.held_out}
    return words


def audit(episodes: Iterable[tuple[str, str, SymbolicEpisode]],
          held_out: set[str]) -> AuditReport:
    """Audit ``(split_id, part, episode)`` triples."""
    report = AuditReport()
    owners: dict[str, dict[str, set[str]]] = defaultdict(lambda: defaultdict(set))
    entropies: dict[int, set[str]] = defaultdict(set)
    held_words = sorted(held_out, key=len, reverse=True)
    word_re = re.compile(r"\b(" + "|".join(re.escape(w) for w in held_words) + r")\b")
    counts: dict[str, int] = defaultdict(int)
    pair_shown = pair_missing = lang_leak = lang_missing = word_leak = 0
    for split_id, part, ep in episodes:
        key = f"{split_id}/{part}"
        counts[key] += 1
        spec = load_split(split_id)
        config = spec.config(part, ep.seed.index)
        entropies[ep.seed.entropy].add(key)
        scene = ep.scene.content_hash
        triple = content_hash([scene, ep.program.to_list(), ep.instruction.to_dict()])
        keys = {
            "seeds": f"{ep.seed.entropy}/{ep.seed.index}/{ep.seed.attempt}",
            "ids": ep.id,
            "scenes": scene,
            "(scene, program, instruction) triples": triple,
            "instruction texts (reported only)": ep.instruction.text.lower(),
        }
        for kind, value in keys.items():
            owners[kind][value].add(key)
        pairs = {(o.shape, o.colour) for o in ep.scene.objects}
        held = set(spec.held_out_pairs)
        if held and set(config.pairs).isdisjoint(held) and pairs & held:
            pair_shown += 1
        if config.required_pairs:
            used = {
                (ep.scene.objects[i].shape, ep.scene.objects[i].colour)
                for s in ep.grounded for i in (s.subject, s.reference)
            }
            if not used & set(config.required_pairs):
                pair_missing += 1
        uses_held = ep.instruction.held_out_template or bool(ep.instruction.held_out_synonyms)
        if config.held_out == "exclude":
            lang_leak += uses_held
            if word_re.search(ep.instruction.text.lower()):
                word_leak += 1
        elif not uses_held:
            lang_missing += 1
    report.parts = dict(sorted(counts.items()))
    for kind, table in owners.items():
        report.shared[kind] = sum(1 for v in table.values() if len(v) > 1)
    report.shared["entropies used by two parts"] = sum(1 for v in entropies.values() if len(v) > 1)
    report.held_out = {
        "held-out combinations shown where excluded": pair_shown,
        "instances lacking a required held-out combination": pair_missing,
        "held-out templates/synonyms where excluded (flags)": lang_leak,
        "held-out words found in excluded instruction texts": word_leak,
        "instructions lacking required held-out language": lang_missing,
    }
    for kind, n in report.shared.items():
        if n and "reported only" not in kind:
            report.failures.append(f"{n} {kind} shared across parts")
    for kind, n in report.held_out.items():
        if n:
            report.failures.append(f"{n} {kind}")
    return report
