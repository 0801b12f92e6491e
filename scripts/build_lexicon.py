"""Rebuild the committed lexicon (``reference_model/language/lexicon.json``) offline.

Usage::

    apt-get install wordnet-base                    # Debian's WordNet 3.0 database
    .venv/bin/pip install -e ".[dev]"               # nltk (dev extra) and matplotlib
    .venv/bin/python scripts/build_lexicon.py            # rewrite the lexicon
    .venv/bin/python scripts/build_lexicon.py --check    # exit 1 where it differs

Sources, read here and nowhere else (the package reads only the JSON this writes):

- **WordNet 3.0** from Debian's ``wordnet-base`` (its folder found with
  ``dpkg -L wordnet-base``, or ``--wordnet DIR``), read with nltk's
  ``WordNetCorpusReader`` from a temporary copy (nltk reads corpora only under its data
  path; Debian ships no ``lexnames``, written here from the database's documented list;
  ``map_wn`` is switched off, it opens ``index.sense``, which ``wordnet-base`` lacks).
  The words of a handful of named synsets (:data:`SEEDS`), their hyponyms where stated,
  adjective satellites, ``-most`` adjectives, ordinals, superlatives and inflections
  (WordNet's exception lists, else the regular rules of English).
- **The xkcd colour survey** (CC0) as matplotlib ships it
  (``matplotlib._color_data.XKCD_COLORS``): every name, its one-word names and first words,
  read as one of the world's seven colours or as a colour the world lacks by the hue rule
  of :func:`colour_class`.
- **Closed-class words** WordNet does not hold (negation particles, modal verbs, question
  words, pronouns of reference): :data:`CLOSED_CLASS`, written here.
- **Hand corrections** (``reference_model/language/lexicon_corrections.json``), applied last.

Nothing else is read: not the robustness suite's word lists (``nsrmp_bench/robustness/``,
its test lexicon above all), nor the generator's templates (held-out words included);
``tests/reference_model/test_lexicon.py`` checks that with an audit hook. The output's
bytes depend only on the inputs: keys sorted, lists sorted, no dates.
"""

from __future__ import annotations

import argparse
import colorsys
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "reference_model" / "language" / "lexicon.json"
CORRECTIONS = REPO / "reference_model" / "language" / "lexicon_corrections.json"
NOTICE = REPO / "NOTICE"
SCRIPT = "scripts/build_lexicon.py"
VERSION = "lexicon-v1"
SCHEMA_VERSION = "1.0.0"
ABSENT = "absent"

# The 45 lexicographer files of WordNet 3.0 in number order (wndb(5WN), lexnames(5WN));
# Debian's wordnet-base documents them in lexnames.5WN but ships no lexnames file.
LEXNAMES = (
    "adj.all", "adj.pert", "adv.all", "noun.Tops", "noun.act", "noun.animal", "noun.artifact",
    "noun.attribute", "noun.body", "noun.cognition", "noun.communication", "noun.event",
    "noun.feeling", "noun.food", "noun.group", "noun.location", "noun.motive", "noun.object",
    "noun.person", "noun.phenomenon", "noun.plant", "noun.possession", "noun.process",
    "noun.quantity", "noun.relation", "noun.shape", "noun.state", "noun.substance", "noun.time",
    "verb.body", "verb.change", "verb.cognition", "verb.communication", "verb.competition",
    "verb.consumption", "verb.contact", "verb.creation", "verb.emotion", "verb.motion",
    "verb.perception", "verb.possession", "verb.social", "verb.stative", "verb.weather",
    "adj.ppl",
)
_LEX_POS = {"adj": 3, "adv": 4, "noun": 1, "verb": 2}

# (category, value) -> WordNet synsets whose lemmas take that reading; a synset marked
# "+" also gives its hyponyms (transitively); value ABSENT: a known concept the world lacks.
SEEDS: dict[tuple[str, str], tuple[str, ...]] = {
    ("shape", "cube"): ("cube.n.01", "cube.n.05", "block.n.03", "hexahedron.n.01"),
    ("shape", "dice"): ("die.n.01",),
    ("shape", "lego"): ("lego.n.01", "brick.n.01"),
    ("shape", ABSENT): ("sphere.n.02", "ball.n.03", "ball.n.01", "cylinder.n.01",
                        "pyramid.n.01", "cone.n.01", "cone.n.02", "prism.n.01",
                        "tetrahedron.n.01", "octahedron.n.01", "dodecahedron.n.01",
                        "icosahedron.n.01", "torus.n.01", "disk.n.01", "ring.n.02",
                        "marble.n.02", "bottle.n.01", "cup.n.01", "bowl.n.01"),
    ("object", "any"): ("object.n.01", "thing.n.04", "item.n.03", "piece.n.02",
                        "block.n.01"),
    ("action", "put"): ("put.v.01", "move.v.02", "transfer.v.02", "set_down.v.04",
                        "shift.v.02", "position.v.01", "relocate.v.02", "plank.v.02",
                        "lay.v.02", "transport.v.02"),
    ("action", "stack"): ("stack.v.02", "pile.v.01", "stack.n.01"),
    ("action", ABSENT): ("rotate.v.04", "revolve.v.01", "flip.v.05", "throw.v.01",
                         "remove.v.01/remove", "paint.v.02", "shake.v.01", "roll.v.01",
                         "lift.v.02", "tilt.v.01", "destroy.v.01"),
    ("relation", "left"): ("left.a.01", "left.n.01", "left.r.01", "left-hand.s.02"),
    ("relation", "right"): ("right.a.01", "right.n.02", "right.r.04", "right-hand.s.01"),
    ("relation", "behind"): ("behind.r.01", "rear.n.02", "back.n.03", "back.s.01",
                             "rear.s.01", "backward.r.01"),
    ("relation", "front"): ("front.n.01", "front.n.04", "front.n.09", "ahead.r.01",
                            "forward.r.01"),
    ("relation", "top"): ("atop.r.01", "top.n.01", "top.n.02"),
    ("relation", ABSENT): ("below.r.01", "beneath.r.01", "underneath.r.01", "inside.r.01",
                           "bottom.n.01", "between.r.01", "near.r.01", "adjacent.s.01",
                           "nearby.s.01"),
    ("negation", "not"): ("not.r.01", "never.r.01", "no.r.01", "no.r.02", "none.r.01"),
    ("colour", ABSENT): ("orange.n.02", "brown.n.01", "grey.n.05", "black.n.01",
                         "pink.n.01", "orange.s.01", "brown.s.01", "grey.s.01",
                         "black.a.01", "pink.s.01"),
}

# The seven world colours: their noun synsets (with hyponyms) and adjective synsets
# (with satellites); a word whose xkcd RGB is known is read by its hue instead.
COLOUR_SEEDS: dict[str, tuple[str, ...]] = {
    "red": ("red.n.01", "red.s.01"),
    "blue": ("blue.n.01", "blue.s.01"),
    "green": ("green.n.01", "green.s.01"),
    "yellow": ("yellow.n.01", "yellow.s.01"),
    "cyan": ("cyan.n.01",),
    "magenta": ("magenta.n.01", "magenta.s.01"),
    "white": ("white.n.02", "white.a.01"),
}
_HYPONYMS_OF = {"red.n.01", "blue.n.01", "green.n.01", "yellow.n.01", "white.n.02",
                "orange.n.02", "brown.n.01", "grey.n.05", "pink.n.01", "black.n.01"}

# Closed-class words (WordNet holds nouns, verbs, adjectives and adverbs, not these).
CLOSED_CLASS: dict[tuple[str, str], tuple[str, ...]] = {
    ("negation", "not"): ("not", "n't", "no", "never", "none", "nothing", "nobody",
                          "neither", "nor", "without", "don't", "dont", "doesn't", "doesnt",
                          "didn't", "didnt", "won't", "wont", "can't", "cant", "cannot",
                          "shouldn't", "shouldnt", "mustn't", "mustnt", "isn't", "isnt",
                          "aren't", "arent", "wouldn't", "wouldnt", "couldn't", "couldnt",
                          "nowhere"),
    ("modality", "ability"): ("can", "could", "able"),
    ("modality", "request"): ("would", "will", "please", "kindly"),
    ("modality", "obligation"): ("must", "should", "shall", "ought", "need", "needs",
                                 "have to", "has to"),
    ("modality", "possibility"): ("may", "might", "maybe", "perhaps", "possibly"),
    ("modality", "volition"): ("want", "wants", "wish", "like", "prefer", "rather"),
    ("question", "what"): ("what",),
    ("question", "which"): ("which",),
    ("question", "where"): ("where",),
    ("question", "who"): ("who", "whom", "whose"),
    ("question", "why"): ("why",),
    ("question", "how"): ("how",),
    ("question", "when"): ("when",),
    ("question", "whether"): ("whether",),
    ("reference", "it"): ("it", "its", "itself", "them", "they", "their", "those", "these",
                          "this", "that"),
    ("reference", "one"): ("one", "ones"),
    ("reference", "there"): ("there", "here"),
    ("reference", "same"): ("same", "other", "another", "former", "latter", "else"),
    ("relation", "top"): ("on", "onto", "upon", "atop", "over", "above"),
    ("relation", ABSENT): ("under", "below", "beneath", "underneath", "inside", "into",
                           "within", "between", "among", "around", "beside", "near",
                           "next to", "close to", "near to", "in between"),
    ("relation", "behind"): ("behind",),
    ("relation", "front"): ("in front of",),
}

# Superlatives read from WordNet's -most adjectives by a word of their gloss, and the
# bases whose -est forms (WordNet's exceptions, else the regular rule) are superlatives.
MOST_GLOSS = (("left", "left"), ("right", "right"), ("rear", "behind"), ("back", "behind"),
              ("front", "front"), ("forward", "front"), ("top", "top"), ("upper", "top"),
              ("high", "top"), ("bottom", "bottom"), ("low", "bottom"), ("far", "far"),
              ("near", "near"), ("close", "near"))
SUPERLATIVE_BASES = {"near": "near", "close": "near", "high": "top",
                     "low": "bottom", "big": ABSENT, "large": ABSENT, "small": ABSENT,
                     "little": ABSENT, "tall": ABSENT, "short": ABSENT}
MAX_ORDINAL = 15  # the world's most objects

# The hue rule's chromatic prototypes: the world's six hues as rendered, and the chromatic
# basic colour terms the world lacks (xkcd's RGB for those names); black and grey are
# decided before, by saturation and value.
ABSENT_PROTOTYPES = ("orange", "brown", "pink")
_WHITE_SATURATION = 0.2
_WHITE_VALUE = 0.75
_DARK_VALUE = 0.25


def wordnet_folder() -> Path:
    """The folder of Debian's WordNet database (``dpkg -L wordnet-base``)."""
    try:
        out = subprocess.run(["dpkg", "-L", "wordnet-base"], capture_output=True, text=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        msg = f"wordnet-base is not installed ({exc}); run: apt-get install wordnet-base"
        raise SystemExit(msg) from exc
    for line in out.splitlines():
        if line.endswith("/data.noun"):
            return Path(line).parent
    msg = "wordnet-base lists no data.noun; reinstall it: apt-get install --reinstall wordnet-base"
    raise SystemExit(msg)


@contextmanager
def open_wordnet(folder: Path) -> Iterator[Any]:
    """nltk's ``WordNetCorpusReader`` over a temporary copy of ``folder``."""
    import nltk  # type: ignore[import-untyped]
    from nltk.corpus.reader.wordnet import WordNetCorpusReader  # type: ignore[import-untyped]

    with tempfile.TemporaryDirectory(prefix="nsrmp-wordnet-") as tmp:
        root = Path(tmp) / "corpora" / "wordnet"
        root.mkdir(parents=True)
        for f in sorted(p for p in folder.iterdir() if p.is_file()):
            shutil.copyfile(f, root / f.name)
        (root / "lexnames").write_text(
            "".join(f"{i:02d}\t{n}\t{_LEX_POS[n.split('.')[0]]}\n"
                    for i, n in enumerate(LEXNAMES)), "utf-8")
        nltk.data.path.insert(0, tmp)
        saved = WordNetCorpusReader.map_wn
        WordNetCorpusReader.map_wn = lambda self, *a, **k: None  # opens index.sense
        try:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # "multilingual functions are not available"
                yield WordNetCorpusReader(nltk.data.find("corpora/wordnet"), None)
        finally:
            WordNetCorpusReader.map_wn = saved
            nltk.data.path.remove(tmp)


def _word(lemma: str) -> str | None:
    """A WordNet lemma as the lexicon's key (lower case, spaces), or None for one that is
    not a plain word or phrase."""
    w = lemma.replace("_", " ").lower()
    return w if re.fullmatch(r"[a-z][a-z' -]*[a-z]|[a-z]", w) else None


def _synset_words(wn: Any, name: str, hyponyms: bool) -> Iterator[tuple[str, str]]:
    """The words of synset ``name`` (``NAME/LEMMA``: that lemma only), of its adjective
    satellites (not the ``-most`` ones: superlatives) and, where asked, its hyponyms."""
    name, _, only = name.partition("/")
    s = wn.synset(name)
    group = [s, *s.similar_tos()] if s.pos() in "as" else [s]
    if hyponyms:
        group += sorted(s.closure(lambda x: x.hyponyms()), key=lambda x: x.name())
    for syn in group:
        for lemma in syn.lemma_names():
            w = _word(lemma)
            if w and (not only or lemma == only) and not (syn is not s and w.endswith("most")):
                yield w, syn.name()


class Builder:
    """The lexicon's entries as they are added: word -> {(category, value): source}."""

    def __init__(self) -> None:
        self.entries: dict[str, dict[tuple[str, str], str]] = {}

    def add(self, word: str, category: str, value: str, source: str,
            replace: bool = False) -> None:
        senses = self.entries.setdefault(word, {})
        if replace:
            for key in [k for k in senses if k[0] == category]:
                del senses[key]
        senses.setdefault((category, value), source)

    def has(self, word: str, category: str) -> bool:
        return any(c == category for c, _ in self.entries.get(word, {}))


def add_wordnet(b: Builder, wn: Any) -> None:
    """Seeds, colours, superlatives, ordinals and inflections from WordNet."""
    # the world's readings first; a concept it lacks only for words with no other reading
    for (category, value), names in sorted(SEEDS.items(), key=lambda kv: (kv[0][1] == ABSENT,
                                                                          kv[0])):
        for name in names:
            for w, syn in _synset_words(wn, name, hyponyms=name in _HYPONYMS_OF):
                if category == "colour" or not b.has(w, category):
                    b.add(w, category, value, f"wordnet:{syn}")
    for value, names in sorted(COLOUR_SEEDS.items()):
        for name in names:
            for w, syn in _synset_words(wn, name, hyponyms=name in _HYPONYMS_OF):
                b.add(w, "colour", value, f"wordnet:{syn}")
    # -most adjectives (leftmost, hindmost, uppermost) by their gloss
    for syn in sorted(wn.all_synsets("a"), key=lambda s: s.name()):
        for lemma in syn.lemma_names():
            most = _word(lemma)
            if not most or not most.endswith("most") or " " in most:
                continue
            gloss = set(re.findall(r"[a-z]+", syn.definition().lower())) | {most[:-4]}
            for key, value in MOST_GLOSS:
                if key in gloss or most.startswith(key):
                    b.add(most, "superlative", value, f"wordnet:{syn.name()}")
                    break
    # -est forms that WordNet's morphology reads back as the base
    for base, value in sorted(SUPERLATIVE_BASES.items()):
        for form in _est_forms(wn, base):
            b.add(form, "superlative", value, f"wordnet:{base}+est")
    # ordinals: adjective synsets with a numeral lemma (second.s.01: second, 2nd, 2d)
    for syn in sorted(wn.all_synsets("a"), key=lambda s: s.name()):
        names = syn.lemma_names()
        nums = {int(m.group(1)) for n in names
                if (m := re.fullmatch(r"(\d+)(st|nd|rd|th|d)", n))}
        if len(nums) == 1 and 1 <= min(nums) <= MAX_ORDINAL:
            num = str(min(nums))
            for lemma in names:
                ordinal = _word(lemma)
                if ordinal:
                    b.add(ordinal, "ordinal", num, f"wordnet:{syn.name()}")
                    for adv in _ordinal_adverbs(wn, ordinal):
                        b.add(adv, "ordinal", num, f"wordnet:{syn.name()}")
    for name in ("farthest.r.01", "furthest.r.01"):
        for w, syn in _synset_words(wn, name, hyponyms=False):
            b.add(w, "superlative", "far", f"wordnet:{syn}")
    for name, value in (("last.s.02", "last"), ("penultimate.s.01", "second-last"),
                        ("last.r.01", "last")):
        for w, syn in _synset_words(wn, name, hyponyms=False):
            if w in {"last", "final", "penultimate", "next-to-last", "lastly", "finally"}:
                b.add(w, "ordinal", value, f"wordnet:{syn}")
    # inflections of the action verbs (WordNet's exception list, else the regular rules)
    for w in sorted(b.entries):
        for (category, value), source in sorted(b.entries[w].items()):
            if category == "action" and " " not in w and ".v." in source:
                for form in _verb_forms(wn, w):
                    if form not in b.entries:
                        b.add(form, category, value, f"{source}+inflection")


def _est_forms(wn: Any, base: str) -> list[str]:
    """The superlatives of adjective ``base``: WordNet's exceptions (far: farthest,
    furthest), else the regular form."""
    exc = sorted(f for f, bases in wn._exception_map["a"].items()
                 if base in bases and f.endswith("est"))
    if exc:
        return exc
    if base.endswith("e"):
        return [base + "st"]
    if re.fullmatch(r"[^aeiou]*[aeiou][bdgmnpt]", base):
        return [base + base[-1] + "est"]
    return [base + "est"]


def _ordinal_adverbs(wn: Any, word: str) -> list[str]:
    form = word + "ly"
    return [form] if wn.synsets(form, "r") else []


_SAME_PAST = frozenset({"put", "set", "cut", "let", "hit", "shut", "cast"})


def _verb_forms(wn: Any, verb: str) -> list[str]:
    """The inflected forms of ``verb``: WordNet's exceptions (lay: laid; take: took,
    taken), and the regular rules of English for the rest."""
    exc = {f for f, bases in wn._exception_map["v"].items() if verb in bases}
    if re.search(r"(s|x|z|ch|sh)$", verb):
        third = verb + "es"
    elif re.search(r"[^aeiou]y$", verb):
        third = verb[:-1] + "ies"
    else:
        third = verb + "s"
    if verb.endswith("ee"):
        stem_ed, stem_ing = verb[:-1], verb
    elif verb.endswith("e"):
        stem_ed = stem_ing = verb[:-1]
    elif re.fullmatch(r"[^aeiou]*[aeiou][bdgklmnprt]", verb):  # one syllable, CVC: stop
        stem_ed = stem_ing = verb + verb[-1]
    elif re.search(r"[^aeiou]y$", verb):
        stem_ed, stem_ing = verb[:-1] + "i", verb
    else:
        stem_ed = stem_ing = verb
    forms = {third, stem_ing + "ing"}
    if verb not in _SAME_PAST and not exc:  # irregular verbs: their past is in exc
        forms.add(stem_ed + "ed")
    return sorted((forms | exc) - {verb})


def srgb_to_lab(rgb: tuple[float, float, float]) -> tuple[float, float, float]:
    """CIELAB (D65) of an sRGB colour with components in [0, 1]."""
    lin = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb]
    x = (0.4124 * lin[0] + 0.3576 * lin[1] + 0.1805 * lin[2]) / 0.95047
    y = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
    z = (0.0193 * lin[0] + 0.1192 * lin[1] + 0.9505 * lin[2]) / 1.08883

    def f(t: float) -> float:
        return t ** (1 / 3) if t > 216 / 24389 else (24389 / 27 * t + 16) / 116

    fx, fy, fz = f(x), f(y), f(z)
    return 116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)


def _hue_angle(lab: tuple[float, ...]) -> float:
    return math.degrees(math.atan2(lab[2], lab[1])) % 360.0


def prototypes(xkcd: dict[str, tuple[float, float, float]]) -> dict[str, tuple[float, ...]]:
    """Lab of each prototype: the world's chromatic colours as rendered, and the basic
    colour terms the world lacks (``absent:NAME``), from xkcd's RGB."""
    from nsrmp_bench.vocabulary import COLOUR_RGBA

    out: dict[str, tuple[float, ...]] = {name: srgb_to_lab(rgba[:3])
                                         for name, rgba in COLOUR_RGBA.items()
                                         if name != "white"}
    for name in ABSENT_PROTOTYPES:
        out[f"{ABSENT}:{name}"] = srgb_to_lab(xkcd[name])
    return out


def colour_class(rgb: tuple[float, float, float], protos: dict[str, tuple[float, ...]]) -> str:
    """The hue rule: a pale unsaturated colour is white, a grey or very dark one is absent;
    any other is the chromatic prototype nearest in CIELAB hue angle (LCh), ``absent``
    where that prototype is a colour the world lacks. Hue, not distance in Lab: the
    world's colours are far more saturated than most named ones."""
    _, s, v = colorsys.rgb_to_hsv(*rgb)
    if s < _WHITE_SATURATION:
        return "white" if v >= _WHITE_VALUE else ABSENT
    if v < _DARK_VALUE:
        return ABSENT
    hue = _hue_angle(srgb_to_lab(rgb))

    def dist(p: tuple[float, ...]) -> float:
        d = abs(hue - _hue_angle(p)) % 360.0
        return min(d, 360.0 - d)

    best = min(sorted(protos), key=lambda name: dist(protos[name]))
    return ABSENT if best.startswith(ABSENT) else best


def xkcd_table() -> dict[str, tuple[float, float, float]]:
    """matplotlib's xkcd colour survey table: name -> RGB."""
    from matplotlib import _color_data, colors

    return {name.removeprefix("xkcd:"): colors.to_rgb(hexa)
            for name, hexa in sorted(_color_data.XKCD_COLORS.items())}


def add_xkcd(b: Builder, wn: Any) -> None:
    """Every xkcd name (phrases too), its one-word names, and the first words of its
    names where they all agree (``kelly`` of ``kelly green``) and WordNet knows the word
    as no adjective or adverb (not ``really`` of ``really light blue``, ``almost`` of
    ``almost black``, ``clear`` of ``clear blue``: modifiers, not names)."""
    table = xkcd_table()
    protos = prototypes(table)
    read = {name: colour_class(rgb, protos) for name, rgb in table.items()}
    for name, value in sorted(read.items()):
        key = _word(name.replace("/", " "))
        if key:
            b.add(key, "colour", value, f"xkcd:{name}", replace=True)
    first: dict[str, set[str]] = {}
    for name, value in read.items():
        words = re.findall(r"[a-z]+", name)
        if len(words) > 1:
            first.setdefault(words[0], set()).add(value)
    for word, values in sorted(first.items()):
        if (len(values) == 1 and word not in b.entries and len(word) > 2
                and not wn.synsets(word, "a") and not wn.synsets(word, "r")):
            b.add(word, "colour", next(iter(values)), "xkcd:first-word")


def add_closed_class(b: Builder) -> None:
    for (category, value), words in sorted(CLOSED_CLASS.items()):
        for w in words:
            b.add(w, category, value, "closed-class")


def add_core(b: Builder) -> None:
    """The world's own names (``nsrmp_bench.vocabulary``) read as themselves."""
    from nsrmp_bench.vocabulary import COLOURS, RELATIONS, SHAPES

    for name in COLOURS:
        b.add(name, "colour", name, "world", replace=True)
    for name in SHAPES:
        b.add(name, "shape", name, "world", replace=True)
    for name in RELATIONS:
        b.add(name, "relation", name, "world", replace=True)
    b.add("top", "relation", "top", "world", replace=True)


def apply_corrections(b: Builder, corrections: list[dict[str, str]]) -> None:
    """Hand corrections: ``remove`` a (word, category) reading, or ``set`` one."""
    for c in corrections:
        word, category = c["word"], c["category"]
        senses = b.entries.get(word, {})
        if c["action"] == "remove":
            for key in [k for k in senses if k[0] == category]:
                del senses[key]
            if word in b.entries and not senses:
                del b.entries[word]
        elif c["action"] == "set":
            b.add(word, category, c["value"], "hand", replace=True)
        else:
            msg = f"correction {c!r}: action must be 'remove' or 'set'"
            raise SystemExit(msg)


PRIORITY = ("shape", "colour", "object", "action", "relation", "superlative", "ordinal",
            "negation", "modality", "question", "reference")


def wordnet_licence() -> str:
    """The WordNet 3.0 licence as the repository's NOTICE holds it (its notice must appear
    on all copies, so the data file carries it too)."""
    text = NOTICE.read_text("utf-8")
    start = text.index("WordNet Release 3.0")
    end = text.index("Princeton University and LICENSEE agrees to preserve same.")
    body = text[start:end] + "Princeton University and LICENSEE agrees to preserve same."
    return "\n".join(line.strip() for line in body.splitlines())


def build(folder: Path) -> dict[str, Any]:
    """The lexicon as JSON-able data, from WordNet in ``folder``, xkcd and the corrections."""
    corrections = json.loads(CORRECTIONS.read_text("utf-8"))["corrections"]
    b = Builder()
    with open_wordnet(folder) as wn:
        add_wordnet(b, wn)
        add_xkcd(b, wn)
    add_closed_class(b)
    add_core(b)
    apply_corrections(b, corrections)
    entries = {
        w: [{"category": c, "value": v, "source": s}
            for (c, v), s in sorted(senses.items(),
                                    key=lambda kv: (PRIORITY.index(kv[0][0]), kv[0][1]))]
        for w, senses in sorted(b.entries.items()) if senses
    }
    counts: dict[str, dict[str, int]] = {}
    for senses in entries.values():
        for sense in senses:
            per = counts.setdefault(sense["category"], {})
            per[sense["value"]] = per.get(sense["value"], 0) + 1
    return {
        "version": VERSION,
        "schema_version": SCHEMA_VERSION,
        "absent": ABSENT,
        "categories": list(PRIORITY),
        "_provenance": {
            "script": SCRIPT,
            "rebuild": ("apt-get install wordnet-base; pip install -e '.[dev]'; "
                        f"python {SCRIPT} (--check compares)"),
            "sources": {
                "wordnet": ("WordNet 3.0 (Debian package wordnet-base), read with nltk's "
                            "WordNetCorpusReader. WordNet 3.0 Copyright 2006 by Princeton "
                            "University. All rights reserved. Used under the WordNet 3.0 "
                            "licence: wordnet_licence below, and the repository's NOTICE."),
                "xkcd": ("xkcd colour survey names and RGB (Randall Munroe, CC0 1.0), as "
                         "matplotlib ships them (matplotlib._color_data.XKCD_COLORS)."),
                "closed-class": f"function words written in {SCRIPT} (CLOSED_CLASS)",
                "world": "the world's own names (nsrmp_bench.vocabulary)",
                "hand": "reference_model/language/lexicon_corrections.json",
            },
            "wordnet_licence": wordnet_licence(),
            "not_read": ("the robustness suite's word lists (nsrmp_bench/robustness/) and the "
                         "generator's templates: never used to build or select this file"),
        },
        "counts": counts,
        "entries": entries,
    }


def render(data: dict[str, Any]) -> bytes:
    """The file's bytes: sorted keys, one entry a line, a final newline."""
    head = {k: v for k, v in data.items() if k != "entries"}
    lines = [json.dumps(head, sort_keys=True, ensure_ascii=True)[:-1] + ', "entries": {']
    items = sorted(data["entries"].items())
    for i, (word, senses) in enumerate(items):
        comma = "," if i < len(items) - 1 else ""
        lines.append(f" {json.dumps(word)}: {json.dumps(senses, sort_keys=True)}{comma}")
    lines.append("}}")
    return ("\n".join(lines) + "\n").encode("ascii")


def main(argv: Iterable[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--wordnet", type=Path, help="WordNet dict folder (default: dpkg -L)")
    parser.add_argument("--check", action="store_true", help="only compare; exit 1 if stale")
    args = parser.parse_args(list(argv) if argv is not None else None)
    folder = args.wordnet or wordnet_folder()
    data = render(build(folder))
    if args.check:
        same = OUTPUT.is_file() and OUTPUT.read_bytes() == data
        print(f"{OUTPUT.relative_to(REPO)}: {'up to date' if same else 'differs; rebuild it'}")
        return 0 if same else 1
    tmp = OUTPUT.with_suffix(".json.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, OUTPUT)
    words = len(json.loads(data)["entries"])
    print(f"wrote {OUTPUT.relative_to(REPO)} ({len(data):,} bytes, {words:,} words)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
