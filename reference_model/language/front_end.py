"""What a person says, read into the words a program model was trained on.

A program model's vocabulary is its training instructions' words; anything else reads as
``<unk>``, and an unknown word at the edge of an instruction starts a step. The front end
rewrites an instruction before the model reads it, word by word, then sentence by sentence:

1. **casing and punctuation**: lower case; ``!``, ``?`` and ``;`` end a sentence as ``.``
   does; a missing final stop is added.
2. **English spatial phrases** the model's training instructions did not use are read
   as the ones they mean (:data:`SPATIAL_WORDS`, :data:`SPATIAL_PHRASES`: ``above`` ->
   ``on top of``; ``at the left of`` -> ``to the left of``), when the model knows the
   words of the meaning.
3. **each word the model does not know** is, in this order: a colour name read as the
   world colour nearest in hue (:mod:`.colour_names`: ``crimson`` -> ``red``); a known
   stem (``leftwards`` -> ``left``) or two known words run together (``rightside``); a
   typo of a known word (the known word at the smallest optimal-string-alignment distance, at most
   ``typo_edits`` edits for words of ``typo_long`` letters or more and one edit for
   shorter ones, never for words under ``typo_min`` letters; rapidfuzz); a synonym
   (``synonyms``: the known word nearest in a sentence-embedding space, if the extra is
   installed and the similarity clears ``synonym_threshold``); else dropped: a word
   the model never saw carries nothing it can use.
4. **sentences that name no object** ("Thank you.", "That's all.") are dropped: a step
   always names the object it moves (a word read as a synonym does not count: "many" must
   not make "Many thanks." name "one"). An instruction left with no sentence asks for no
   action, and the model predicts the empty program (nothing moves).
5. **a fronted destination** ("To the right of the blue cube, put the red block.") goes
   back after its clause: a sentence or clause that begins with a spatial preposition and
   holds a comma is read with the part before that comma moved to its end.

What is known in advance (the rest is the model's, learnt): the world's colour and shape
names and the nouns for "an object" (:data:`OBJECT_WORDS`, to tell a sentence that names
an object), English spatial prepositions (:data:`PREPOSITIONS`) and the few that mean one
of the world's actions or relations in other words (:data:`SPATIAL_WORDS`,
:data:`SPATIAL_PHRASES`), colour names with their
RGB values, and, with the ``language`` extra, a general sentence-embedding model.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Final

from nsrmp_bench._optional import require
from nsrmp_bench.reference_model.language.colour_names import colour_of_name
from nsrmp_bench.vocabulary import COLOURS, SHAPES

__all__ = ["OBJECT_WORDS", "PREPOSITIONS", "SPATIAL_PHRASES", "SPATIAL_WORDS", "FrontEnd",
           "Reading"]

OBJECT_WORDS: Final = frozenset({*COLOURS, *SHAPES, "box", "die", "brick", "block", "object",
                                 "thing", "one"})
"""Words that name an object: a sentence without one asks for no step (a step always
names the object it moves)."""
PREPOSITIONS: Final = frozenset({"on", "onto", "upon", "atop", "to", "left", "right",
                                 "beside", "above", "over", "at", "leftwards",
                                 "rightwards", "leftward", "rightward"})
"""Spatial prepositions (and the two sides) that begin a fronted destination."""
SPATIAL_WORDS: Final[dict[str, str]] = {"above": "on top of"}
"""A spatial word and the phrase of the world's action it means ("put the cube above the
dice": on top of it; the world has no "above" other than on top)."""
SPATIAL_PHRASES: Final[dict[tuple[str, ...], tuple[str, ...]]] = {
    ("at", "the", "left", "of"): ("to", "the", "left", "of"),
    ("at", "the", "right", "of"): ("to", "the", "right", "of"),
}
"""Spatial phrases and the phrase they mean ("the cube at the left of the dice")."""
_TOKEN: Final = re.compile(r"[a-z]+|[.,!?;]")
_ENDS: Final = frozenset(".!?;")
_CLAUSE_STARTS: Final = frozenset({"then", "and", "finally", "lastly", "afterwards"})
_STEP_CONNECTORS: Final = frozenset({"then", "after", "afterwards", "finally", "lastly"})
_NAMING: Final = OBJECT_WORDS | {"it"}
_DROPPED: Final = "\0"  # where a word the model never saw was
_SYNONYM: Final = "\1"  # marks a word read as a synonym: it does not make a sentence name an object

Synonyms = Callable[[str, Sequence[str]], str | None]
"""Nearest known word to an unknown one (or None): ``(word, known words) -> word``."""


@dataclass(frozen=True)
class Reading:
    """An instruction as the model will read it, and what the front end changed."""

    text: str
    changes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def empty(self) -> bool:
        """The instruction asks for no action: nothing is left to read."""
        return not self.text


class FrontEnd:
    """Reads instructions into ``known`` words (a model's vocabulary)."""

    def __init__(self, known: Iterable[str], *, typo_edits: int = 2, typo_long: int = 6,
                 typo_min: int = 3, synonyms: Synonyms | None = None,
                 english: frozenset[str] = frozenset()) -> None:
        require("rapidfuzz")  # the language extra
        from rapidfuzz.distance import OSA
        from rapidfuzz.process import extract

        self._distance, self._extract = OSA.distance, extract
        self.known = frozenset(w for w in known if w.isalpha())
        self._choices = sorted(w for w in self.known if len(w) >= 2)
        self.typo_edits, self.typo_long, self.typo_min = typo_edits, typo_long, typo_min
        self.synonyms = synonyms
        self.english = english
        self._cache: dict[str, tuple[str | None, str]] = {}

    def word(self, w: str) -> tuple[str | None, str]:
        """A word the model knows for ``w`` (or None: drop it) and how it was found."""
        if w in self.known:
            return w, "known"
        hit = self._cache.get(w)
        if hit is None:
            hit = self._resolve(w)
            self._cache[w] = hit
        return hit

    def _resolve(self, w: str) -> tuple[str | None, str]:
        spatial = SPATIAL_WORDS.get(w)
        if spatial is not None and self.known.issuperset(spatial.split()):
            return spatial, "spatial"
        colour = colour_of_name(w)
        if colour is not None and colour in self.known:
            return colour, "colour"
        for suffix in ("wards", "ward", "s"):
            stem = w.removesuffix(suffix)
            if stem != w and stem in self.known:
                return stem, "stem"
        for i in range(3, len(w) - 2):  # a compound of two known words: "rightside"
            if w[:i] in self.known and w[i:] in self.known:
                return f"{w[:i]} {w[i:]}", "compound"
        if len(w) >= self.typo_min and w not in self.english:
            limit = self.typo_edits if len(w) >= self.typo_long else 1
            found = self._extract(w, self._choices, scorer=self._distance,
                                  score_cutoff=limit, limit=None)
            if found:
                best = min(found, key=lambda m: (m[1], m[0][:1] != w[:1],
                                                 m[0] not in OBJECT_WORDS,
                                                 abs(len(m[0]) - len(w)), m[0]))
                return best[0], "typo"
        if self.synonyms is not None:
            near = self.synonyms(w, self._choices)
            if near is not None:
                return near, "synonym"
        return None, "dropped"

    def read(self, text: str) -> Reading:
        """``text`` as the model will read it (see the module doc)."""
        changes: list[str] = []
        sentences: list[list[str]] = [[]]
        for tok in self._spatial_phrases(_TOKEN.findall(text.lower()), changes):
            if tok in _ENDS:
                if sentences[-1]:
                    sentences.append([])
                continue
            if tok == ",":
                sentences[-1].append(tok)
                continue
            new, how = self.word(tok)
            if how != "known":
                changes.append(f"{tok} -> {new}" if new is not None else f"{tok} dropped")
            if new is None:
                sentences[-1].append(_DROPPED)
            else:
                mark = _SYNONYM if how == "synonym" else ""
                sentences[-1].extend(w + mark for w in new.split())
        kept: list[list[str]] = []
        for s in sentences:
            words = [t for t in s if t not in (",", _DROPPED)]
            if not words:
                continue
            if not OBJECT_WORDS.intersection(words):
                changes.append(f"sentence {' '.join(words)!r} dropped: it names no object")
                continue
            kept.append(self._unfront(_without_filler_chunks(s, changes), changes))
        text_out = " . ".join(" ".join(_tidy(s)).replace(_SYNONYM, "") for s in kept)
        return Reading(f"{text_out} ." if text_out else "", tuple(changes))

    def _spatial_phrases(self, tokens: list[str], changes: list[str]) -> list[str]:
        """``tokens`` with each phrase of :data:`SPATIAL_PHRASES` read as its meaning,
        where the model knows the meaning's words."""
        out: list[str] = []
        i = 0
        while i < len(tokens):
            for phrase, meaning in SPATIAL_PHRASES.items():
                if (tuple(tokens[i:i + len(phrase)]) == phrase
                        and self.known.issuperset(meaning)):
                    out.extend(meaning)
                    changes.append(f"{' '.join(phrase)} -> {' '.join(meaning)}")
                    i += len(phrase)
                    break
            else:
                out.append(tokens[i])
                i += 1
        return out

    def _unfront(self, sentence: list[str], changes: list[str]) -> list[str]:
        """A clause that begins with a preposition and a phrase naming an object, then a
        comma: that phrase moved to the clause's end (the sentence's end or the next step
        connector)."""
        out = list(sentence)
        starts = [0] + [i + 1 for i, t in enumerate(out[:-1])
                        if t in _CLAUSE_STARTS or (t == "that" and i > 0 and out[i - 1] == "after")]
        for start in starts:
            while start < len(out) and (out[start] == "," or (
                    out[start] in (*_CLAUSE_STARTS, "next")
                    and start + 1 < len(out) and out[start + 1] == ",")):
                start += 1
            if start >= len(out) or out[start] not in PREPOSITIONS:
                continue
            try:
                comma = out.index(",", start)
            except ValueError:
                continue
            end = _step_end(out, comma + 2)
            while end > comma + 1 and out[end - 1] in (",", "and"):
                end -= 1
            fronted, clause = out[start:comma], out[comma + 1:end]
            if not _NAMING.intersection(fronted) or not clause:
                continue
            changes.append(f"fronted {' '.join(fronted)!r} moved after its clause")
            out = out[:start] + clause + fronted + out[end:]
            break
        return out


def _step_end(tokens: list[str], begin: int) -> int:
    """Where the step that goes on at ``begin`` ends: at a step connector ("then",
    "afterwards", ...; not at "then put it", the step's own second verb), or at an "and"
    that starts a clause of its own, not one inside a noun phrase ("and is cyan", "and
    blue in colour") nor the step's own second verb ("and put it down")."""
    for i in range(begin, len(tokens)):
        t = tokens[i]
        if t in _STEP_CONNECTORS and "it" not in tokens[i + 1:i + 4]:
            return i
        if t == "and":
            after = tokens[i + 1:i + 4]
            if after and after[0] not in ("is", "in", "has", *COLOURS) and "it" not in after:
                return i
    return len(tokens)


def _without_filler_chunks(sentence: list[str], changes: list[str]) -> list[str]:
    """The sentence without its comma-separated chunks that name no object and held a word
    the model never saw or read as a synonym ("I reckon", "when you have a moment", "if
    possible"): they carry nothing it can use. The marks of dropped words go too."""
    chunks: list[list[str]] = [[]]
    for t in sentence:
        if t == ",":
            chunks.append([])
        else:
            chunks[-1].append(t)
    kept: list[str] = []
    for chunk in chunks:
        unsure = _DROPPED in chunk or any(t.endswith(_SYNONYM) for t in chunk)
        if unsure and not _NAMING.intersection(chunk):
            words = [t for t in chunk if t != _DROPPED]
            if words:
                changes.append(f"chunk {' '.join(words)!r} dropped: a filler")
            continue
        if kept:
            kept.append(",")
        kept.extend(t for t in chunk if t != _DROPPED)
    return kept


def _tidy(tokens: list[str]) -> list[str]:
    """No comma at either end of a sentence, none twice in a row."""
    out: list[str] = []
    for t in tokens:
        if t == "," and (not out or out[-1] == ","):
            continue
        out.append(t)
    while out and out[-1] == ",":
        out.pop()
    return out
