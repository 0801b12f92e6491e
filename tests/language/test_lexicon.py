"""The committed lexicon (``reference_model/language/lexicon.json``) and its loader
(``reference_model/language/lexicon.py``); no torch, no WordNet. Its build is tested in
``tests/scripts/test_build_lexicon.py``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from script_module import load_script

from nsrmp_bench.errors import DataIntegrityError, InvalidArgument, SchemaVersionError
from nsrmp_bench.reference_model.language.lexicon import (
    ABSENT,
    CATEGORIES,
    Lexicon,
    Status,
    load_lexicon,
    lookup,
)
from nsrmp_bench.vocabulary import COLOURS, RELATIONS, SHAPES

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "reference_model" / "language" / "lexicon.json"
CORRECTIONS = REPO / "reference_model" / "language" / "lexicon_corrections.json"


# ----- the loader -----------------------------------------------------------------------

@pytest.mark.parametrize(("word", "category", "value"), [
    ("cube", "shape", "cube"), ("Cubes", "shape", "cube"), ("hexahedron", "shape", "cube"),
    ("box", "shape", "cube"), ("die", "shape", "dice"), ("dice", "shape", "dice"),
    ("legos", "shape", "lego"), ("brick", "shape", "lego"),
    ("block", "object", "any"), ("object", "object", "any"),
    ("cherry", "colour", "red"), ("kelly", "colour", "green"), ("kelly green", "colour", "green"),
    ("mustard", "colour", "yellow"), ("teal", "colour", "cyan"),
    ("placed", "action", "put"), ("plop", "action", "put"), ("stacking", "action", "stack"),
    ("atop", "relation", "top"), ("rear", "relation", "behind"), ("ahead", "relation", "front"),
    ("leftmost", "superlative", "left"), ("nearest", "superlative", "near"),
    ("frontmost", "superlative", "front"), ("second", "ordinal", "2"), ("first", "ordinal", "1"),
    ("last", "ordinal", "last"),
    ("don't", "negation", "not"), ("Don\u2019t", "negation", "not"), ("never", "negation", "not"),
    ("could", "modality", "ability"), ("which", "question", "which"),
    ("it", "reference", "it"),
])
def test_a_word_reads_as_its_category_and_canonical_value(word: str, category: str,
                                                          value: str) -> None:
    r = lookup(word)
    assert r.status is Status.KNOWN
    assert (r.category, r.value) == (category, value), r


@pytest.mark.parametrize(("word", "category"), [
    ("orange", "colour"), ("grey", "colour"), ("gray", "colour"), ("black", "colour"),
    ("brown", "colour"), ("sphere", "shape"), ("cylinder", "shape"), ("balls", "shape"),
    ("under", "relation"), ("below", "relation"), ("rotate", "action"),
])
def test_what_the_world_lacks_is_known_to_be_absent(word: str, category: str) -> None:
    r = lookup(word)
    assert r.status is Status.ABSENT
    assert (r.category, r.value) == (category, ABSENT)


@pytest.mark.parametrize("word", ["xyzzy", "the", "", "   "])
def test_a_word_the_lexicon_lacks_is_unknown(word: str) -> None:
    r = lookup(word)
    assert r.status is Status.UNKNOWN and r.senses == () and r.category is None


def test_the_world_names_read_as_themselves() -> None:
    for name, category in [*((c, "colour") for c in COLOURS), *((s, "shape") for s in SHAPES),
                           *((r, "relation") for r in RELATIONS)]:
        assert lookup(name).sense(category).value == name  # type: ignore[union-attr]


def test_a_word_of_two_categories_keeps_both_with_the_world_first() -> None:
    r = lookup("brick")  # a lego brick, and xkcd's brick colour (a red)
    assert r.status is Status.KNOWN and r.category == "shape" and r.value == "lego"
    colour = r.sense("colour")
    assert colour is not None and colour.value == "red" and colour.source == "xkcd:brick"


def test_words_lists_by_category_and_value() -> None:
    lex = load_lexicon()
    assert "hexahedron" in lex.words("shape", "cube")
    assert "orange" in lex.words("colour", ABSENT)
    assert lex.words("colour") == sorted(lex.words("colour"))
    assert "crimson" in lex and "xyzzy" not in lex and len(lex) > 1000


def test_lookup_refuses_what_is_not_a_word() -> None:
    with pytest.raises(InvalidArgument, match="str"):
        lookup(3)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgument, match="at most"):
        lookup("a" * 1000)


def test_the_loader_refuses_another_major_version_and_malformed_entries() -> None:
    with pytest.raises(SchemaVersionError, match="rebuild"):
        Lexicon({"schema_version": "2.0.0", "entries": {}})
    with pytest.raises(DataIntegrityError, match="entries"):
        Lexicon({"schema_version": "1.0.0"})
    with pytest.raises(DataIntegrityError, match="'cube'"):
        Lexicon({"schema_version": "1.0.0", "entries": {"cube": [{"category": "shape"}]}})
    with pytest.raises(DataIntegrityError, match="categories"):
        Lexicon({"schema_version": "1.0.0",
                 "entries": {"cube": [{"category": "food", "value": "x", "source": "s"}]}})


def test_the_loader_needs_neither_torch_nor_nltk() -> None:
    code = ("import sys; from nsrmp_bench.reference_model.language.lexicon import lookup; "
            "assert lookup('crimson').value == 'red'; "
            "print(sorted(m for m in ('torch', 'nltk', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


# ----- the committed file ---------------------------------------------------------------

def test_the_file_is_small_canonical_and_says_where_it_comes_from() -> None:
    raw = DATA.read_bytes()
    assert len(raw) <= 2 * 1024 * 1024
    data = json.loads(raw)
    assert load_script("build_lexicon").render(data) == raw  # sorted keys, one entry a line
    about = data["_provenance"]
    assert about["script"] == "scripts/build_lexicon.py" and "--check" in about["rebuild"]
    assert "Copyright 2006 by Princeton University" in about["wordnet_licence"]
    assert "CC0" in about["sources"]["xkcd"]
    assert data["categories"] == list(CATEGORIES)
    notice = (REPO / "NOTICE").read_text("utf-8")
    assert "WordNet 3.0 Copyright 2006 by Princeton University" in notice


def test_every_hand_correction_is_applied_and_says_why() -> None:
    corrections = json.loads(CORRECTIONS.read_text("utf-8"))["corrections"]
    assert corrections
    entries = json.loads(DATA.read_bytes())["entries"]
    for c in corrections:
        assert c["why"].strip(), c
        senses = [s for s in entries.get(c["word"], []) if s["category"] == c["category"]]
        if c["action"] == "set":
            assert senses == [{"category": c["category"], "value": c["value"],
                               "source": "hand"}], c
        else:
            assert c["action"] == "remove" and senses == [], c
