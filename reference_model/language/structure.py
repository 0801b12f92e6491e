"""The reader of sentence structure (nsrm-v4, nmn-v4): what an instruction asks for, before
a program model reads it.

nsrm-v3's front end made every sentence that names an object a step and dropped every word
it did not know. This reader reads clauses, on the committed lexicon (:mod:`.lexicon`) and
a few closed-class words of English written here, and rewrites the instruction into what
the networks read (nsrm-v3's front end then reads that):

- **steps begin where actions begin**: a sentence of taking ("Pick up the red cube.", no
  destination) and the next one that puts "it" somewhere are one step;
- **negation has scope**: a negated or keeping clause ("without touching X", "but do not
  move X", "and leave X where it is", "and keep X in place") is a constraint, no step; a
  sentence that is one ("Don't move the red lego.", "Leave X alone.") asks for nothing; an
  instruction of nothing else asks for no action;
- **questions and remarks** (a sentence ending in "?" that is not a request, or one with no
  verb or modal of doing) ask for no action;
- **a self-correction** ("..., no, on the green one", "..., sorry, I mean the white one")
  replaces the destination or the noun phrase it corrects;
- **ellipsis** ("..., then the green one on top of it"): a clause without a verb but with a
  noun phrase and a destination is a step with the verb before; "the green one" is the
  shape of the phrase it refers back to; "it" there is the previous step's subject
  (:attr:`Structure.base_previous`);
- **a referent the world lacks** (a colour or shape the lexicon knows as absent: "grey",
  "pyramid") makes the instruction not feasible; whether a colour-shape pair is in the
  scene, or which object a phrase picks out, the model answers from its own perception;
- **superlatives** ("the leftmost cube", "the second dice from the right", "the lego
  nearest to the robot") become the DSL's ``extreme[side, rank]``
  (:attr:`Structure.extremes`), resolved by the model on the positions it sees;
- **unknown words stay** where they are (the front end reads them as it can); the reader
  counts them (:attr:`Structure.unknown`): they lower the model's confidence.

A pure function of the text: no torch, no scene.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Final

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.language.lexicon import Status, lookup
from nsrmp_bench.vocabulary import COLOURS, MAX_STEPS, SHAPES

__all__ = ["NOT_FEASIBLE", "NO_ACTION", "Extreme", "Structure", "read_structure", "tokens"]

NO_ACTION: Final = "no action"
NOT_FEASIBLE: Final = "not feasible"

_TOKEN: Final = re.compile(r"[a-z]+(?:'[a-z]+)?|[.,;:!?]")
_CONTRACTIONS: Final[dict[str, tuple[str, ...]]] = {
    "don't": ("do", "not"), "doesn't": ("does", "not"), "didn't": ("did", "not"),
    "can't": ("can", "not"), "won't": ("will", "not"), "isn't": ("is", "not"),
    "aren't": ("are", "not"), "shouldn't": ("should", "not"), "mustn't": ("must", "not"),
    "it's": ("it", "is"), "that's": ("that", "is"), "let's": ("let", "us"),
    "i'm": ("i", "am"), "what's": ("what", "is"), "where's": ("where", "is"),
}
PUT_VERBS: Final = frozenset({"put", "place", "move", "set", "stack", "position", "drop",
                              "lay", "shift", "transfer", "bring", "slide", "push",
                              "relocate", "reposition", "carry", "deposit", "rest"})
"""Verbs that start a step (besides the lexicon's actions of value put, move or stack)."""
TAKE_VERBS: Final = frozenset({"pick", "take", "grab", "grasp", "lift", "hold", "get",
                               "raise", "collect", "seize", "fetch"})
"""Verbs of taking: a step's first half ("Pick up X."), its destination to come."""
DIRECTIVES: Final = frozenset({"should", "supposed", "must", "ought", "ensure", "needs",
                               "need", "wants", "want", "let", "belongs", "belong", "goes",
                               "go", "carry", "carries", "support", "supports", "gets", "get"})
DIRECTIVE_PHRASES: Final = ("form a tower", "make a stack", "build a tower", "make a tower",
                            "has to", "have to", "would like", "make sure", "end up",
                            "ends up", "to be", "your job", "your task", "use the robot",
                            "using the robot", "with the robot")
"""Words of a sentence that asks for something to be done without an imperative verb
("The red cube should be on the dice."); a sentence with none and no verb is a remark."""
_POLITE_MODALS: Final = frozenset({"could", "can", "would", "will"})
_KEEP_VERBS: Final = frozenset({"leave", "keep"})
_STILL: Final = ("where it is", "alone", "in place", "untouched", "as it is", "still",
                 "where it stands", "in its place", "put")
_STEP_CONNECTORS: Final = ("then", "after that", "and then", "and after that", "afterwards",
                           "next", "and afterwards", "finally", "lastly", "after this")
_MARKERS: Final = ("no , i mean", "sorry , i mean", "no , sorry ,", "no ,", "sorry ,",
                   "i mean", "or rather", "rather ,", "actually ,", "no sorry ,")
DESTINATIONS: Final = tuple(sorted((
    "on top of", "on to", "onto", "on", "atop", "upon", "over", "above", "to the left of",
    "to the right of", "left of", "right of", "on the left of", "on the right of",
    "on the left side of", "on the right side of", "to the left side of",
    "to the right side of", "at the left of", "at the right of", "beside",
    "on the left hand side of", "on the right hand side of", "just left of",
    "just right of", "just on", "right on top of", "just to the left of",
    "just to the right of"), key=lambda s: -len(s.split())))
"""Phrases that begin a destination, longest first."""
_QUALIFIERS: Final = frozenset({"is", "are", "that", "which", "sits", "lies", "stands",
                                "located", "found", "lying", "sitting", "standing", "being"})
_SIDES: Final[dict[str, str]] = {"left": "left", "right": "right", "back": "behind",
                                 "rear": "behind", "front": "front"}
_ROBOT: Final = frozenset({"robot", "arm", "panda"})
_VIEWER: Final = frozenset({"you", "me", "camera", "viewer", "us"})
SHAPE_NOUNS: Final[dict[str, str]] = {"cube": "cube", "box": "cube", "dice": "dice",
                                      "die": "dice", "lego": "lego", "brick": "lego"}


@dataclass(frozen=True)
class Extreme:
    """A superlative: ``extreme[side, rank]`` of the phrase it sits in, which is the
    ``role`` (``subject`` or ``base``) of step ``step`` (0-based, as the reader counts)."""

    side: str
    rank: int
    step: int
    role: str
    words: str  # as said, for the notes
    generic: bool = False  # the phrase names no colour or shape: every object is in its set
    at: int = 0  # where it was in its sentence (the reader's bookkeeping)


@dataclass(frozen=True)
class Structure:
    """What an instruction asks for: the text the model reads, or an abstention."""

    text: str
    abstain: str | None = None
    steps: int = 0  # steps the reader counts (actions)
    base_previous: tuple[int, ...] = ()  # steps whose base is the previous step's subject
    extremes: tuple[Extreme, ...] = ()
    constraints: tuple[str, ...] = ()  # what must stay where it is (as said)
    unknown: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    said: str = ""  # the text before superlatives were taken out: where phrases are checked

    @property
    def changed(self) -> bool:
        """Whether the reader rewrote anything (else the model reads the text as nsrm-v3)."""
        return bool(self.notes)


def tokens(text: str) -> list[str]:
    """Lower-cased words and punctuation, contractions opened, curly apostrophes straight."""
    text = text.replace("\u2019", "'").replace("\u2018", "'").lower()
    out: list[str] = []
    for tok in _TOKEN.findall(text):
        if tok in _CONTRACTIONS:
            out.extend(_CONTRACTIONS[tok])
        else:
            out.append(tok.removesuffix("'s"))
    return out


def _sense(word: str) -> tuple[str | None, str | None, Status]:
    if word in COLOURS:
        return "colour", word, Status.KNOWN
    if word in SHAPES:
        return "shape", word, Status.KNOWN
    r = lookup(word)
    return r.category, r.value, r.status


def is_put_verb(word: str) -> bool:
    """A verb that starts a step."""
    if word in PUT_VERBS:
        return True
    cat, value, status = _sense(word)
    return cat == "action" and status is Status.KNOWN and value in ("put", "move", "stack")


def is_negation(word: str) -> bool:
    """A word that negates its clause ("no" is a correction's marker, not here)."""
    if word in ("not", "never", "without", "nor"):
        return True
    cat, _, _ = _sense(word)
    return cat == "negation" and word not in ("no", "none")


def _find(words: list[str], phrase: str, start: int = 0) -> int:
    p = phrase.split()
    for i in range(start, len(words) - len(p) + 1):
        if words[i:i + len(p)] == p:
            return i
    return -1


def destination(words: list[str], start: int = 0) -> tuple[int, int] | None:
    """(begin, end) of the last destination phrase in ``words[start:]`` outside a
    qualifier ("that is to the left of")."""
    best: tuple[int, int] | None = None
    i = start
    while i < len(words):
        for phrase in DESTINATIONS:
            n = len(phrase.split())
            if " ".join(words[i:i + n]) == phrase:
                if not _QUALIFIERS.intersection(words[max(0, i - 1):i]):
                    best = (i, i + n)
                i += n - 1
                break
        i += 1
    return best


def _starts_with_destination(words: list[str]) -> int:
    for phrase in DESTINATIONS:
        if " ".join(words[:len(phrase.split())]) == phrase:
            return len(phrase.split())
    return 0


def _shape_of(words: list[str]) -> str | None:
    for w in words:
        if w in SHAPE_NOUNS:
            return w
        cat, value, status = _sense(w)
        if cat == "shape" and status is Status.KNOWN and value:
            return w
    return None


def _with_shape(words: list[str], antecedent: list[str]) -> list[str]:
    """"the green one" -> "the green cube" when the antecedent names a cube."""
    if "one" not in words or _shape_of(words) is not None:
        return words
    shape = _shape_of(antecedent)
    if shape is None:
        return words
    i = words.index("one")
    return [*words[:i], shape, *words[i + 1:]]


def _sentences(toks: list[str]) -> list[tuple[list[str], str]]:
    out: list[tuple[list[str], str]] = []
    cur: list[str] = []
    for t in toks:
        if t in (".", "!", "?", ";"):
            if cur:
                out.append((cur, t))
            cur = []
        else:
            cur.append(t)
    if cur:
        out.append((cur, "."))
    return out


def _polite_request(words: list[str]) -> bool:
    """"Could you put the red cube on the dice?" is a request, not a question."""
    return bool(words) and words[0] in _POLITE_MODALS and "you" in words[:3] and any(
        is_put_verb(w) or w in TAKE_VERBS for w in words[2:6])


def _acts(words: list[str]) -> bool:
    """Whether a sentence asks for something to be done."""
    text = f" {' '.join(words)} "
    return any(is_put_verb(w) or w in TAKE_VERBS or w in DIRECTIVES for w in words) or any(
        f" {p} " in text for p in DIRECTIVE_PHRASES)


def _prohibition(words: list[str]) -> bool:
    """A sentence that forbids ("Don't move X.", "Leave X alone.", "Never touch X.")."""
    head = [w for w in words[:4] if w not in ("please", "and", "but", "just", "kindly")]
    if head[:2] in (["do", "not"], ["never", *head[1:2]]) or head[:1] == ["never"]:
        return True
    return bool(head) and head[0] in _KEEP_VERBS and _keeps(words)


def _keeps(words: list[str]) -> bool:
    text = " ".join(words)
    return any(f" {s}" in f" {text}" for s in _STILL) and destination(words) is None


def _constraint_start(words: list[str]) -> int:
    """Where a constraint clause begins in a sentence that also acts (-1: none)."""
    for i, w in enumerate(words):
        if i == 0:
            continue
        if w == "without":
            return i
        if w in ("and", "but", ","):
            rest = [x for x in words[i + 1:] if x not in (",", "please", "just")]
            if rest[:2] == ["do", "not"] or rest[:1] == ["never"] or (
                    rest[:1] and rest[0] in _KEEP_VERBS
                    and _keeps(rest[:_constraint_end(rest, 0)])):
                return i
            if rest[:1] == ["making"] and "not" in rest[:8]:
                return i
    return -1


def _constraint_end(words: list[str], start: int) -> int:
    """A constraint runs to the sentence's end or the next step connector."""
    for i in range(start + 1, len(words)):
        if (words[i] == "," and " ".join(words[i + 1:i + 3]) in ("then", "after that")) or (
                words[i] == "," and words[i + 1:i + 2] == ["then"]):
            return i
    return len(words)


def read_structure(text: str) -> Structure:
    """The structure of ``text`` (see the module doc). An instruction with more steps than
    the DSL's :data:`~nsrmp_bench.vocabulary.MAX_STEPS` is an :class:`InvalidArgument`."""
    notes: list[str] = []
    constraints: list[str] = []
    kept: list[list[str]] = []
    absent = [w for w in tokens(text) if _sense(w)[0] in ("colour", "shape")
              and _sense(w)[2] is Status.ABSENT]
    for words, end in _sentences(tokens(text)):
        if end == "?" and not _polite_request(words):
            notes.append(f"question {' '.join(words)!r}: no action")
            continue
        if _prohibition(words):
            notes.append(f"prohibition {' '.join(words)!r}: no step")
            constraints.append(" ".join(words))
            continue
        while (c := _constraint_start(words)) >= 0:
            e = _constraint_end(words, c)
            constraints.append(" ".join(words[c:e]))
            notes.append(f"constraint {' '.join(words[c:e])!r}: no step")
            words = words[:c] + words[e:]
        if kept and words[:1] in (["then"], ["next"], ["after"], ["afterwards"]) \
                and destination(words) is not None and not _acts(words):
            kept[-1] = [*kept[-1], ",", *words]  # ". Then the green one on it."
            notes.append(f"ellipsis {' '.join(words)!r} goes on the sentence before")
            continue
        if not _acts(words):
            notes.append(f"remark {' '.join(words)!r}: no action")
            continue
        kept.append(words)
    kept = _join_taking(kept, notes)
    kept = [_correct(s, notes) for s in kept]
    base_previous: list[int] = []
    extremes: list[Extreme] = []
    out: list[list[str]] = []
    step = 0
    said: list[str] = []
    for s in kept:
        s, step = _ellipsis(s, step, base_previous, notes)
        said.append(" ".join(_tidy(s)) + " .")
        s = _superlatives(s, len(out), extremes, notes)  # step: its sentence, for now
        step += 1
        out.append(s)
    unknown = tuple(w for w in tokens(text) if w.isalpha() and _sense(w)[2] is Status.UNKNOWN)
    step = count_steps([w for s in out for w in (*s, ".")])
    extremes = [_extreme_step(e, out, e.step) for e in extremes]
    if step > MAX_STEPS:
        msg = (f"the instruction {text[:80]!r}... asks for about {step} steps; a program has at "
               f"most {MAX_STEPS} (the DSL's limit): give it as instructions of {MAX_STEPS} "
               f"steps or fewer")
        raise InvalidArgument(msg)
    if absent:
        return Structure("", NOT_FEASIBLE, 0, (), (), tuple(constraints), unknown,
                         (*notes, f"{', '.join(absent)}: not in this world"))
    if not out:
        return Structure("", NO_ACTION, 0, (), (), tuple(constraints), unknown,
                         tuple(notes) or ("nothing to do",))
    if not notes:
        return Structure(text, None, step, (), (), (), unknown, (), text)
    rewritten = " ".join(" ".join(_tidy(s)) + " ." for s in out)
    return Structure(rewritten, None, step, tuple(base_previous), tuple(extremes),
                     tuple(constraints), unknown, tuple(notes), " ".join(said))


def _join_taking(sentences: list[list[str]], notes: list[str]) -> list[list[str]]:
    """"Pick up X. Put it on Y." -> "pick up X and put it on Y" (one step)."""
    out: list[list[str]] = []
    for s in sentences:
        prev = out[-1] if out else None
        head = [w for w in s[:3] if w not in ("now", "then", "and", "please", ",")]
        if prev is not None and len(head) >= 2 and is_put_verb(head[0]) and head[1] == "it" \
                and any(w in TAKE_VERBS for w in prev[:4]) and destination(prev) is None:
            out[-1] = [*prev, "and", *s[s.index(head[0]):]]
            notes.append("a sentence of taking and one that puts it: one step")
        else:
            out.append(s)
    return out


def _correct(words: list[str], notes: list[str]) -> list[str]:
    """A self-correction replaces what it corrects."""
    text = " ".join(words)
    for marker in _MARKERS:
        i = text.find(f", {marker} ")
        if i < 0:
            continue
        before = text[:i].split()
        after = text[i + len(marker) + 3:].split()
        # the correction runs to a step connector
        stop = next((k for k in range(len(after)) if after[k] == "," and " ".join(
            after[k + 1:k + 3]).startswith(("then", "after that", "and then"))), len(after))
        after, rest = after[:stop], after[stop:]
        dest = destination(before)
        if dest is None:
            return words
        n = _starts_with_destination(after)
        if n:
            new = [*before[:dest[0]], *after[:n],
                   *_with_shape(after[n:], before[dest[1]:])]
        else:
            new = [*before[:dest[1]], *_with_shape(after, before[dest[1]:])]
        notes.append(f"correction {' '.join(after)!r} replaces what came before it")
        return _correct([*new, *rest], notes)
    return words


def _ellipsis(words: list[str], step: int, base_previous: list[int],
              notes: list[str]) -> tuple[list[str], int]:
    """Clauses of ``words`` that leave their verb out get the verb back; returns the words
    and the index of the sentence's last step."""
    out: list[str] = []
    clauses = _step_clauses(words)
    for k, (conn, clause) in enumerate(clauses):
        taken = k > 0 and any(w in TAKE_VERBS for w in clauses[k - 1][1][:4]) \
            and destination(clauses[k - 1][1]) is None and "it" in clause[:3]
        if k > 0 and not taken:
            step += 1
        verbless = not _acts(clause)
        dest = destination(clause)
        if k > 0 and verbless and dest is not None and _shape_or_object(clause[:dest[0]]):
            prev = clauses[k - 1][1]
            pdest = destination(prev)
            antecedent = prev[:pdest[0]] if pdest else prev
            subject = _with_shape(clause[:dest[0]], antecedent)
            base = clause[dest[1]:]
            if base in (["it"], ["it", "too"], ["that", "one"]):
                base_previous.append(step)
            clause = ["put", *subject, *clause[dest[0]:]]
            notes.append(f"ellipsis: {' '.join(clause)!r} (the verb before)")
        out.extend([*conn, *clause])
    return out, step


def _step_clauses(words: list[str]) -> list[tuple[list[str], list[str]]]:
    """(connector, clause) pieces of a sentence, cut at ", then" / ", and after that"."""
    pieces: list[tuple[list[str], list[str]]] = [([], [])]
    i = 0
    while i < len(words):
        matched = None
        if i == 0 or words[i - 1] == ",":
            for c in _STEP_CONNECTORS:
                n = len(c.split())
                if " ".join(words[i:i + n]) == c and i > 0:
                    matched = n
                    break
        if matched:
            pieces.append((words[i:i + matched], []))
            i += matched
            continue
        pieces[-1][1].append(words[i])
        i += 1
    return [(c, s) for c, s in pieces if s]


def _shape_or_object(words: list[str]) -> bool:
    return any(w in SHAPE_NOUNS or w in ("one", "block", "object", "thing")
               or _sense(w)[0] in ("colour", "shape") for w in words)


def _superlatives(words: list[str], step: int, extremes: list[Extreme],
                  notes: list[str]) -> list[str]:
    """Superlative phrases read as ``extreme`` and taken out of the words."""
    out = list(words)
    i = 0
    while i < len(out):
        w = out[i]
        cat, value, _ = _sense(w)
        found: tuple[int, int, str, int] | None = None  # begin, end, side, rank
        if cat == "superlative" and value is not None:
            tail = out[i + 1:i + 5]
            if value in ("left", "right", "behind", "front") and not (
                    tail[:1] == ["to"] and tail[1:3] == ["the", tail[2] if len(tail) > 2
                                                         else ""]
                    and len(tail) > 2 and tail[2] in _SIDES):
                found = (i, i + 1, value, 1)
            else:  # "furthest to the left", "nearest to the robot", "closest to you"
                j = i + 1
                while j < len(out) and out[j] in ("to", "the", "from", "of"):
                    j += 1
                if j < len(out) and (out[j] in _SIDES or out[j] in _ROBOT | _VIEWER):
                    near = value in ("near", "top")
                    word = out[j]
                    side = _SIDES.get(word) or (
                        ("behind" if near else "front") if word in _ROBOT
                        else ("front" if near else "behind"))
                    if word in _SIDES and value in ("far",):
                        side = _SIDES[word]
                    found = (i, j + 1, side, 1)
        elif cat == "ordinal" and value is not None and value.isdigit():
            j = _find(out, "from", i)
            if 0 < j - i <= 3 and j + 2 < len(out) + 1:
                k = j + 1
                while k < len(out) and out[k] == "the":
                    k += 1
                if k < len(out) and out[k] in _SIDES:
                    # "the second cube from the right": the words between stay
                    del out[j:k + 1]
                    del out[i]
                    role = _role(out, i)
                    extremes.append(Extreme(_SIDES[out_word(words, k)], int(value), step,
                                            role, " ".join(words), _generic(out, i), i))
                    notes.append(f"superlative: rank {value} towards {extremes[-1].side}")
                    continue
        if found is not None:
            b, e, side, rank = found
            del out[b:e]
            role = _role(out, b)
            extremes.append(Extreme(side, rank, step, role, " ".join(words),
                                    _generic(out, b), b))
            notes.append(f"superlative: rank {rank} towards {side} ({role})")
            continue
        i += 1
    return out


def _generic(words: list[str], at: int) -> bool:
    """Whether the phrase around ``at`` names no colour and no shape ("the leftmost
    thing", "the second block from the right")."""
    if not words:
        return True
    at = min(at, len(words) - 1)
    left = at
    while left > 0 and at - left < 4 and words[left] not in ("the", "a"):
        left -= 1
    right = at
    while right < len(words) - 1 and right - at < 4 and not (
            words[right] in SHAPE_NOUNS or words[right] in ("thing", "object", "block",
                                                            "one", "item", "piece")):
        right += 1
    phrase = words[left:right + 1]
    return not any(w in SHAPE_NOUNS or _sense(w)[0] in ("colour", "shape") for w in phrase)


def out_word(words: list[str], k: int) -> str:
    """The side word of an ordinal's "from the SIDE" in the original words."""
    for w in words[words.index("from"):] if "from" in words else words:
        if w in _SIDES:
            return w
    return words[min(k, len(words) - 1)]


def _role(words: list[str], at: int) -> str:
    """Whether position ``at`` is in the subject or the base of its step: before its
    clause's destination phrase, the subject."""
    start = 0
    for k in range(at - 1, -1, -1):
        if words[k] == "," or is_put_verb(words[k]) or words[k] in TAKE_VERBS:
            start = k
            break
    end = at
    while end < len(words) and words[end] not in (",", "then", "after", "afterwards", "and"):
        end += 1
    dest = destination(words[:end], start)
    if dest is None:
        return "subject"
    return "subject" if at <= dest[0] else "base"


def _tidy(words: list[str]) -> list[str]:
    """No comma at a sentence's end, none twice in a row."""
    out: list[str] = []
    for w in words:
        if w == "," and (not out or out[-1] == ","):
            continue
        out.append(w)
    while out and out[-1] in (",", "and", "but"):
        out.pop()
    return out


_COUNT_CUTS: Final = frozenset({",", "and", "then", "afterwards", "next", "finally", "lastly",
                                "after", "."})
_NEW_STEP: Final = frozenset({"then", "afterwards", "next", "finally", "lastly", "after", "."})
_MODALS: Final = frozenset({"should", "supposed", "must", "ought", "ensure", "needs", "need",
                            "wants", "want", "belongs", "goes"})


def _verb_at(c: list[str]) -> int | None:
    """The first verb of a clause that acts: of putting, of taking, or a modal of doing;
    not a participle inside a qualifier ("the cube that is placed ...", "the block
    that sits ...")."""
    for i, w in enumerate(c):
        if not (is_put_verb(w) or w in TAKE_VERBS or w in _MODALS):
            continue
        before = c[i - 1] if i else ""
        if w.endswith(("ed", "ing")) and before in ("is", "are", "be", "was") \
                and w not in _MODALS:
            continue
        if before in ("that", "which", "who") and w not in _MODALS and not (
                i > 1 and c[i - 2] == "after"):
            continue
        return i
    return None


def count_steps(words: list[str]) -> int:
    """How many steps an instruction (its sentences joined by ``.``) asks for: its clauses
    that act (a verb of putting or taking, a modal of doing: "should", "needs", "make
    sure"; or, after "then" or a new sentence, an ellipsis), a clause that puts "it" after
    one that took something being the same step."""
    clauses: list[tuple[str, list[str]]] = [(".", [])]
    for k, w in enumerate(words):
        if w in _COUNT_CUTS and not (w == "next" and words[k + 1:k + 2] == ["to"]):
            clauses.append((w, []))
        elif not (w == "that" and not clauses[-1][1] and clauses[-1][0] == "after"):
            clauses[-1][1].append(w)
    n = 0
    taking = False
    for cut, c in clauses:
        if not c:
            continue
        text = f" {' '.join(c)} "
        verb = _verb_at(c)
        acts = verb is not None or any(f" {p} " in text for p in (
            "has to", "have to", "make sure", "would like", "form a tower", "make a stack",
            "build a tower", "make a tower"))
        if not acts:
            dest = destination(c)
            if n and cut in _NEW_STEP and dest is not None and _shape_or_object(c[:dest[0]]) \
                    and not {"is", "are", "it"}.intersection(c[:dest[0]]):
                n += 1  # an ellipsis: "then the green one on top of it"
                taking = False
            continue
        if taking and verb is not None and "it" in c[verb + 1:verb + 3]:
            taking = False
            continue
        n += 1
        taking = verb is not None and c[verb] in TAKE_VERBS
    return n


def _extreme_step(e: Extreme, sentences: list[list[str]], k: int) -> Extreme:
    """``e`` with its step counted as the instruction's steps up to its clause's end."""
    words = [w for s in sentences[:k] for w in (*s, ".")]
    own = sentences[k]
    end = e.at
    while end < len(own) and own[end] not in _COUNT_CUTS:
        end += 1
    n = count_steps([*words, *own[:end]])
    return replace(e, step=max(0, n - 1))


_NP_STOPS: Final = frozenset({"left", "right", "behind", "front", "before", "back", "on",
                              "onto", "to", "beside", "next", "near", "atop", "above", "over",
                              "upon", "under", "below", "so", "without", "then", "while",
                              "alongside", "by", "rear", "at", "in", "towards", "into",
                              "from", "closest", "nearest", "furthest", "farthest", "just"})
_RELATION_STOPS: Final = frozenset({"behind", "front", "before", "back", "rear", "near",
                                    "at", "in"})
_ATTRIBUTE_LINKS: Final = frozenset({"is", "a", "an", "and", "that", "which", "whose",
                                     "has", "colour", "color", "shape", "of", "looks", "like",
                                     "coloured", "colored", "the", "in", "one", "sits",
                                     "lies", "found", "can", "be", "located", "thing",
                                     "object", "block", "item"})


@dataclass(frozen=True)
class NounPhrase:
    """A plain noun phrase (no relation, no superlative): its world colour and shape."""

    words: tuple[str, ...]
    colour: str | None
    shape: str | None


def plain_phrases(text: str) -> list[NounPhrase]:
    """The noun phrases of ``text`` that name an object by its colour and/or shape alone
    ("the red cube", "the block which is a lego and is magenta"): the phrases whose
    referent a model can check against what it sees. Phrases that refer through another
    object, rank ("leftmost"), say "only", or name an unknown word are left out."""
    words = tokens(text)
    out: list[NounPhrase] = []
    i = 0
    while i < len(words):
        if words[i] != "the" or (i > 0 and words[i - 1] in ("has", "like")) or words[
                i + 1:i + 2] in (["shape"], ["left"], ["right"], ["back"], ["front"],
                                 ["top"], ["rear"], ["robot"], ["table"]):
            i += 1
            continue
        j = i + 1
        colour = shape = None
        bad = False
        while j < len(words):
            w = words[j]
            if w in (",", ".", ";", "?", "!") or is_put_verb(w) or w in TAKE_VERBS \
                    or w in _MODALS:
                break
            if w in _NP_STOPS and not (w == "in" and words[j + 1:j + 2] in (["colour"],
                                                                         ["color"])):
                if w in _RELATION_STOPS or (w in ("left", "right", "on", "to", "beside",
                                                  "next", "by", "alongside")
                                            and words[j - 1] in _QUALIFIERS):
                    bad = True  # refers through another object
                elif not _after_verb(words, i) or _relation_phrases(words, j) >= 2:
                    bad = True  # "the dice left of the red lego to the left of ...": one is
                    # the phrase's own relation
                break
            if w == "the" and words[j - 1] not in ("of", "has", "like", "is"):
                break
            if w == "and" and j + 1 < len(words) and words[j + 1] not in (
                    "is", "a", "an", *COLOURS):
                break
            cat, value, status = _sense(w)
            if w in SHAPE_NOUNS:
                shape = shape or SHAPE_NOUNS[w]
            elif cat == "colour" and status is Status.KNOWN:
                colour = colour or value
            elif cat == "shape" and status is Status.KNOWN:
                shape = shape or value
            elif w in ("only", "single", "sole", "one", "ones", "other", "same") \
                    or cat in ("superlative", "ordinal") or (
                        w not in _ATTRIBUTE_LINKS and w not in ("lego", "die", "dice")
                        and (status is Status.UNKNOWN or cat not in ("object", "reference"))):
                bad = True
            j += 1
        if not bad and (colour or shape):
            out.append(NounPhrase(tuple(words[i:j]), colour, shape))
        i = max(j, i + 1)
    return out


def _relation_phrases(words: list[str], start: int) -> int:
    """How many destination or relation phrases the clause has from ``start`` on."""
    n = 0
    i = start
    while i < len(words):
        w = words[i]
        if w in (",", ".", ";", "then") or (is_put_verb(w) and i > start) or w in TAKE_VERBS:
            break
        if w in _RELATION_STOPS and w != "in":
            n += 1
            i += 1
            continue
        k = _starts_with_destination(words[i:])
        if k:
            n += 1
            i += k
            continue
        i += 1
    return n


def _after_verb(words: list[str], at: int) -> bool:
    """Whether the phrase at ``at`` is a step's subject, just after its verb ("put the red
    cube ..."): a phrase after a destination followed by a relation phrase refers
    through it ("onto the green block to the left of the lego block")."""
    k = at - 1
    while k >= 0 and words[k] in ("up", "down", "over", "please", "just"):
        k -= 1
    return k >= 0 and (is_put_verb(words[k]) or words[k] in TAKE_VERBS)
