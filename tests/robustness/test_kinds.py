"""The perturbation kinds on instructions the generator writes: each deterministic, each
changing (nearly) every instruction, each keeping to its word lists."""

from __future__ import annotations

import re

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.robustness.kinds import (
    CONTROLS,
    KINDS,
    PERTURBATIONS,
    generator_words,
    lexicon,
    perturb_instruction,
)
from nsrmp_bench.robustness.part import instance_rng, shuffled_sources
from nsrmp_bench.vocabulary import COLOURS, SHAPES

WORD = re.compile(r"[a-z]+")


@pytest.fixture(scope="module")
def instructions() -> list[tuple[str, str]]:
    """200 symbolic episodes' (text, lexed) across steps, phrasings and relations."""
    from nsrmp_bench.generators.sampler import first_valid, sample_symbolic
    from nsrmp_bench.split_specs import load_split

    spec = load_split("paper-v2")
    out = []
    for i in range(200):
        config, eid = spec.config("val", i), spec.episode_id("val", i)
        ep = first_valid(spec.part("val").entropy, i,
                         lambda seed, c=config, e=eid: sample_symbolic(c, seed, e),
                         max_attempts=64, what="")
        out.append((ep.instruction.text, ep.instruction.lexed))
    return out


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "shuffled"])
def test_each_kind_is_deterministic_and_changes_nearly_every_instruction(
        kind: str, instructions: list[tuple[str, str]]) -> None:
    changed = 0
    for i, (text, lexed) in enumerate(instructions):
        a = perturb_instruction(kind, text, instance_rng(kind, 0, i), lexed=lexed)
        b = perturb_instruction(kind, text, instance_rng(kind, 0, i), lexed=lexed)
        assert a == b
        assert a.changed == (a.text != text)
        assert a.changed or a.reason, "an unchanged instance says why"
        changed += a.changed
    floor = 0.9 if kind == "reorder" else 0.99
    assert changed >= floor * len(instructions), (kind, changed)


def test_another_seed_gives_other_texts(instructions: list[tuple[str, str]]) -> None:
    texts = [perturb_instruction("polite", t, instance_rng("polite", s, 0)).text
             for t, _ in instructions[:1] for s in range(20)]
    assert len(set(texts)) > 5


def test_typo_edits_content_words_only_and_never_into_a_known_word(
        instructions: list[tuple[str, str]]) -> None:
    known = generator_words()
    for i, (text, _) in enumerate(instructions):
        p = perturb_instruction("typo", text, instance_rng("typo", 0, i))
        before, after = WORD.findall(text.lower()), WORD.findall(p.text.lower())
        assert len(before) == len(after)
        edited = [(a, b) for a, b in zip(before, after, strict=True) if a != b]
        assert 1 <= len(edited) <= 2
        for old, new in edited:
            assert old in lexicon()["typo_targets"]
            assert new not in known and new[0] == old[0]


def test_synonym_lexicons_share_no_word_with_the_generator_or_each_other() -> None:
    known = generator_words()
    test, dev = lexicon("test"), lexicon("dev")
    function = set(test["function_words"])

    def words(lex: dict[str, object]) -> set[str]:
        table = lex["synonym"]
        assert isinstance(table, dict)
        return {w for vs in table.values() for v in vs for w in WORD.findall(v)} - function

    assert not words(test) & known
    assert not words(dev) & known
    assert not words(test) & words(dev)
    for phrase in test["synonym"]:  # what is replaced is what the generator writes
        assert set(WORD.findall(phrase)) <= known, phrase


def test_fillers_and_polite_forms_name_no_object_or_relation() -> None:
    content = {*COLOURS, *SHAPES, "cube", "box", "die", "block", "object", "thing", "left",
               "right", "behind", "front", "top", "put", "place", "move"}
    for name in ("test", "dev"):
        lex = lexicon(name)
        phrases = [*lex["blind"], *(p for group in ("polite", "filler")
                                    for key, vs in lex[group].items()
                                    if key != "not_imperative" for p in vs)]
        for phrase in phrases:
            assert not content & set(WORD.findall(phrase.lower())), phrase


def test_reorder_fronts_the_destination() -> None:
    p = perturb_instruction("reorder", "Put the red cube on top of the blue dice.",
                            np.random.default_rng(0), lexed="Put <S1> on top of <R1>.")
    assert p.text == "On top of the blue dice, put the red cube."
    none = perturb_instruction("reorder", "The blue dice needs the red cube on top.",
                               np.random.default_rng(0), lexed="<R1> needs <S1> on top.")
    assert not none.changed and none.reason


def test_controls() -> None:
    assert set(CONTROLS) | set(PERTURBATIONS) == set(KINDS)
    blind = perturb_instruction("blind", "Put the red cube on the blue dice.",
                                np.random.default_rng(1))
    assert blind.changed and blind.text in lexicon()["blind"]
    other = perturb_instruction("shuffled", "Put A.", np.random.default_rng(0), other="Put B.")
    assert other.text == "Put B."
    same = perturb_instruction("shuffled", "Put A.", np.random.default_rng(0), other="Put A.")
    assert not same.changed and same.reason
    order = shuffled_sources(50, 3)
    assert sorted(order) == list(range(50)) and all(o != i for i, o in enumerate(order))
    assert order == shuffled_sources(50, 3)


@pytest.mark.parametrize(("kind", "text", "match"), [
    ("loud", "Put it.", "perturbation kind 'loud'"),
    ("typo", "   ", "non-empty string"),
    ("shuffled", "Put it.", "other="),
])
def test_bad_input_is_named(kind: str, text: str, match: str) -> None:
    with pytest.raises(InvalidArgument, match=match):
        perturb_instruction(kind, text, np.random.default_rng(0))
