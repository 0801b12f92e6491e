"""The lexicon: what an English word means in this world, from committed data.

``lexicon.json`` beside this module is distilled offline from WordNet 3.0 and the xkcd
colour survey by ``scripts/build_lexicon.py`` (its header says how to rebuild it; the
WordNet licence notice is in the repository's ``NOTICE``). Reading it needs nothing but
the standard library: no torch, no nltk, no WordNet at run time.

:func:`lookup` reads one word (or a phrase the lexicon holds, such as ``kelly green``)
as a :class:`Reading`:

- ``KNOWN``: one or more :class:`Sense` (category and canonical value), best first:
  ``crimson`` -> colour ``red``; ``hexahedron`` -> shape ``cube``; ``placed`` -> action
  ``put``; ``leftmost`` -> superlative ``left``; ``don't`` -> negation ``not``;
- ``ABSENT``: a word the lexicon knows that names something the world lacks (colour
  ``orange``, shape ``sphere``, relation ``under``, action ``rotate``): a reference to it
  can match no object, so a reader should abstain rather than guess;
- ``UNKNOWN``: a word the lexicon does not hold (evidence all the same: a reader keeps it).

Words are read lower-cased, with curly apostrophes straightened; a word the lexicon lacks
is tried without a plural ending (``cubes``, ``dice``'s ``-s`` forms, ``boxes``,
``berries``) before it is unknown.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from functools import cache
from importlib import resources
from typing import Any, Final

from nsrmp_bench.errors import DataIntegrityError, InvalidArgument, SchemaVersionError

__all__ = ["ABSENT", "CATEGORIES", "Lexicon", "Reading", "Sense", "Status", "load_lexicon",
           "lookup"]

ABSENT: Final = "absent"
"""The value of a sense that names something the world lacks."""
CATEGORIES: Final = ("shape", "colour", "object", "action", "relation", "superlative",
                     "ordinal", "negation", "modality", "question", "reference")
"""The lexicon's categories, in the order a word's senses are ranked."""
SCHEMA_MAJOR: Final = 1
MAX_WORD_CHARS: Final = 100
"""Longest word or phrase :func:`lookup` reads (the lexicon's longest key is far shorter)."""
_APOSTROPHES: Final = str.maketrans({"\u2019": "'", "\u2018": "'", "\u02bc": "'"})


class Status(Enum):
    """What the lexicon says of a word."""

    KNOWN = "known"
    ABSENT = "absent"
    UNKNOWN = "unknown"


@dataclass(frozen=True)
class Sense:
    """One reading of a word: its category, canonical value and where it came from
    (``wordnet:SYNSET``, ``xkcd:NAME``, ``closed-class``, ``world`` or ``hand``)."""

    category: str
    value: str
    source: str

    @property
    def absent(self) -> bool:
        """Whether this sense names something the world lacks."""
        return self.value == ABSENT


@dataclass(frozen=True)
class Reading:
    """A word as the lexicon reads it: the normalised ``word``, the ``key`` it was found
    under (``cubes`` -> ``cube``; empty when unknown) and its senses, best first."""

    word: str
    key: str
    senses: tuple[Sense, ...]

    @property
    def status(self) -> Status:
        """``KNOWN`` if any sense is of the world, ``ABSENT`` if all name what it lacks,
        ``UNKNOWN`` without senses."""
        if not self.senses:
            return Status.UNKNOWN
        return Status.ABSENT if all(s.absent for s in self.senses) else Status.KNOWN

    @property
    def best(self) -> Sense | None:
        """The first sense of the world, else the first sense, else None."""
        return next((s for s in self.senses if not s.absent), self.senses[0]
                    if self.senses else None)

    @property
    def category(self) -> str | None:
        """The best sense's category (None when unknown)."""
        return self.best.category if self.best else None

    @property
    def value(self) -> str | None:
        """The best sense's canonical value, :data:`ABSENT` for what the world lacks (None
        when unknown)."""
        return self.best.value if self.best else None

    def sense(self, category: str) -> Sense | None:
        """The word's sense in ``category`` (``brick``: shape ``lego``, colour absent)."""
        return next((s for s in self.senses if s.category == category), None)


class Lexicon:
    """The committed lexicon's entries, read once (:func:`load_lexicon`)."""

    def __init__(self, data: Mapping[str, Any]) -> None:
        version = str(data.get("schema_version", ""))
        if version.split(".")[0] != str(SCHEMA_MAJOR):
            msg = (f"lexicon schema_version {version!r}; this reader knows {SCHEMA_MAJOR}.x: "
                   "rebuild it with scripts/build_lexicon.py or update nsrmp-bench")
            raise SchemaVersionError(msg)
        entries = data.get("entries")
        if not isinstance(entries, Mapping):
            msg = "lexicon has no 'entries' mapping; rebuild it with scripts/build_lexicon.py"
            raise DataIntegrityError(msg)
        self.version = str(data.get("version", ""))
        self._entries: dict[str, tuple[Sense, ...]] = {}
        for word, senses in entries.items():
            try:
                parsed = tuple(Sense(str(s["category"]), str(s["value"]), str(s["source"]))
                               for s in senses)
            except (KeyError, TypeError) as exc:
                msg = (f"lexicon entry {word!r} is malformed ({exc!r}); expected a list of "
                       "{category, value, source}: rebuild it with scripts/build_lexicon.py")
                raise DataIntegrityError(msg) from exc
            unknown = [s.category for s in parsed if s.category not in CATEGORIES]
            if unknown or not parsed:
                msg = (f"lexicon entry {word!r} has categories {unknown or 'none'}; expected "
                       f"some of {list(CATEGORIES)}")
                raise DataIntegrityError(msg)
            self._entries[word] = parsed

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, word: object) -> bool:
        return isinstance(word, str) and self.lookup(word).status is not Status.UNKNOWN

    def words(self, category: str | None = None, value: str | None = None) -> list[str]:
        """The words with a sense in ``category`` (and of ``value``), sorted."""
        return sorted(w for w, senses in self._entries.items()
                      if any((category is None or s.category == category)
                             and (value is None or s.value == value) for s in senses))

    def lookup(self, word: str) -> Reading:
        """What ``word`` (a word, or a phrase the lexicon holds) means here."""
        if not isinstance(word, str):
            msg = f"lookup takes a str, got {type(word).__name__}; pass the word's text"
            raise InvalidArgument(msg)
        if len(word) > MAX_WORD_CHARS:
            msg = (f"word of {len(word)} characters; lookup reads at most {MAX_WORD_CHARS} "
                   "(one word or a short phrase)")
            raise InvalidArgument(msg)
        w = " ".join(word.translate(_APOSTROPHES).lower().split()).strip(".,;:!?\"()")
        for key in _candidates(w):
            senses = self._entries.get(key)
            if senses:
                return Reading(w, key, senses)
        return Reading(w, "", ())


def _candidates(w: str) -> list[str]:
    """``w`` itself, then the singulars its plural ending may hide (last word only)."""
    out = [w]
    head, _, last = w.rpartition(" ")
    prefix = f"{head} " if head else ""
    if last.endswith("ies") and len(last) > 4:
        out.append(prefix + last[:-3] + "y")
    if last.endswith(("ses", "xes", "zes", "ches", "shes")):
        out.append(prefix + last[:-2])
    if last.endswith("s") and not last.endswith("ss") and len(last) > 3:
        out.append(prefix + last[:-1])
    if last.endswith("'s"):
        out.append(prefix + last[:-2])
    return out


@cache
def load_lexicon() -> Lexicon:
    """The committed lexicon (``reference_model/language/lexicon.json``), read once."""
    files = resources.files("nsrmp_bench.reference_model.language")
    try:
        text = files.joinpath("lexicon.json").read_text("utf-8")
        data = json.loads(text)
    except (OSError, ValueError) as exc:
        msg = (f"cannot read the lexicon ({exc}); reinstall nsrmp-bench, or rebuild "
               "reference_model/language/lexicon.json with scripts/build_lexicon.py")
        raise DataIntegrityError(msg) from exc
    return Lexicon(data)


def lookup(word: str) -> Reading:
    """What ``word`` means in this world, from the committed lexicon."""
    return load_lexicon().lookup(word)
