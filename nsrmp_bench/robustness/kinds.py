"""The perturbation kinds: each a pure function of (instruction, random generator).

Every kind keeps the meaning of the instruction (the gold stays right) and changes only its
wording; the two controls (``blind``, ``shuffled``) change the meaning on purpose, to show
whether a model reads the instruction at all. The word lists are data
(``robustness/lexicon.json``); what each kind does, with examples:

- ``polite``: a request form, "please", a closing sentence.
  *Put the red cube onto the blue dice.* -> *Could you please put the red cube onto the
  blue dice, thanks. That's all.*
- ``filler``: hedges and asides that carry no step.
  *Okay, so put the red cube onto the blue dice, no rush.*
- ``typo``: one or two keyboard-adjacent edits (a neighbouring key typed instead, one
  letter more or less, two letters swapped) in content words (colours, shapes, relations,
  verbs), never the first letter and never giving another word the generator uses.
  *Put the rwd cube onto the blue dice.*
- ``synonym``: words replaced by synonyms no template, phrase or synonym list of the
  generator uses (``lexicon.json``'s ``synonym``). *Deposit the crimson cuboid upon the
  blue dotted cuboid.*
- ``reorder``: the destination fronted. *Onto the blue dice, put the red cube.*
- ``case``: casing and punctuation (lower case, upper case, no final stop, "!", no commas).
- ``blind`` (control): an instruction that names no object and no action (*Go ahead.*).
- ``shuffled`` (control): another episode's instruction from the same part (chosen by
  :func:`~nsrmp_bench.robustness.part.shuffled_sources`).

An instruction a kind cannot change is returned unchanged with the reason, never dropped.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any, Final

import numpy as np

from nsrmp_bench.errors import InvalidArgument

__all__ = [
    "CONTROLS",
    "KINDS",
    "LEXICONS",
    "PERTURBATIONS",
    "Perturbed",
    "generator_words",
    "lexicon",
    "perturb_instruction",
]

PERTURBATIONS: Final = ("polite", "filler", "typo", "synonym", "reorder", "case")
"""The kinds that keep the meaning: a model should score as on the unperturbed part."""
CONTROLS: Final = ("blind", "shuffled")
"""The controls: a model that reads the instruction scores far lower on them."""
KINDS: Final = (*PERTURBATIONS, *CONTROLS)

_WORD: Final = re.compile(r"[A-Za-z]+")
_KEYBOARD: Final = ("qwertyuiop", "asdfghjkl", "zxcvbnm")


@dataclass(frozen=True)
class Perturbed:
    """One instruction after a kind: its text, whether it changed, what changed (or why not)."""

    text: str
    changed: bool
    edits: tuple[str, ...] = ()
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (one line of a perturbed part's ``perturbations.jsonl``)."""
        return {"text": self.text, "changed": self.changed, "edits": list(self.edits),
                "reason": self.reason}


LEXICONS: Final = {"test": "lexicon.json", "dev": "lexicon-dev.json"}
"""The suite's word lists (``test``: the boards are made with it) and the development
lists (``dev``: other words for the same kinds, for augmentation and model selection)."""


@cache
def lexicon(name: str = "test") -> dict[str, Any]:
    """The word lists ``name`` (``robustness/lexicon.json`` or ``lexicon-dev.json``)."""
    if name not in LEXICONS:
        msg = f"lexicon {name!r}; expected one of {list(LEXICONS)}"
        raise InvalidArgument(msg)
    files = resources.files("nsrmp_bench.robustness")
    data: dict[str, Any] = json.loads(files.joinpath(LEXICONS[name]).read_text("utf-8"))
    return data


@cache
def generator_words() -> frozenset[str]:
    """Every word the generator's templates, phrases, synonyms and connectors can write
    (held-out ones included), lower case: a typo must not give one of them, and the synonym
    lexicon shares none of them but its function words."""
    base = resources.files("nsrmp_bench.generators").joinpath("templates")
    words: set[str] = set()

    def walk(value: object) -> None:
        if isinstance(value, str):
            words.update(w.lower() for w in _WORD.findall(value))
        elif isinstance(value, dict):
            for k, v in value.items():
                if k not in ("version", "id"):
                    walk(v)
        elif isinstance(value, list):
            for v in value:
                walk(v)

    for name in ("steps.json", "phrases.json", "synonyms.json"):
        walk(json.loads(base.joinpath(name).read_text("utf-8")))
    from nsrmp_bench.vocabulary import COLOURS, SHAPES

    words.update(COLOURS)
    words.update(SHAPES)
    return frozenset(words)


def _choice(rng: np.random.Generator, options: Sequence[str]) -> str:
    return options[int(rng.integers(0, len(options)))]


def _lower_first(text: str) -> str:
    return text[:1].lower() + text[1:] if text[:2] != "I " else text


def _upper_first(text: str) -> str:
    return text[:1].upper() + text[1:]


def _split_final_stop(text: str) -> tuple[str, str]:
    """``text`` without its final punctuation, and that punctuation."""
    body = text.rstrip()
    end = ""
    while body and body[-1] in ".!?":
        end = body[-1] + end
        body = body[:-1]
    return body, end


# -- the kinds ------------------------------------------------------------------------------
def _imperative(lexed: str, text: str, not_imperative: Sequence[str]) -> bool:
    """Whether the instruction starts with a verb (a request form can go before it)."""
    first = (lexed or text).lstrip()
    if first.startswith("<"):
        return False
    m = _WORD.match(first)
    return m is not None and m.group().lower() not in not_imperative


def _some(rng: np.random.Generator, chances: Sequence[float]) -> tuple[bool, ...]:
    """Independent draws with ``chances``, drawn again until at least one is true."""
    while True:
        drawn = tuple(bool(rng.random() < p) for p in chances)
        if any(drawn):
            return drawn


def _opened(body: str, opener: str, edits: list[str], what: str = "opener") -> str:
    edits.append(f"{what} {opener!r}")
    return f"{opener} {_lower_first(body)}" if what == "opener" else f"{opener} {body}"


def _closed(body: str, end: str, closing: str | None, edits: list[str]) -> Perturbed:
    out = body + (end or ".")
    if closing is not None:
        out = f"{out} {closing}"
        edits.append(f"closing {closing!r}")
    return Perturbed(_upper_first(out), True, tuple(edits))


def _polite(text: str, rng: np.random.Generator, lex: dict[str, Any], lexed: str
            ) -> Perturbed:
    polite = lex["polite"]
    body, end = _split_final_stop(text)
    opener, stop, closing = _some(rng, (0.6, 0.4, 0.6))
    edits: list[str] = []
    if opener and _imperative(lexed, text, polite["not_imperative"]):
        body = _opened(body, _choice(rng, polite["openers"]), edits)
    elif opener:
        body = _opened(body, _choice(rng, polite["greetings"]), edits, "greeting")
    if stop:
        s = _choice(rng, polite["in_place_of_final_stop"])
        body, end = body + s[:-1], s[-1]
        edits.append(f"ending {s!r}")
    return _closed(body, end, _choice(rng, polite["closings"]) if closing else None, edits)


def _filler(text: str, rng: np.random.Generator, lex: dict[str, Any]) -> Perturbed:
    filler = lex["filler"]
    body, end = _split_final_stop(text)
    opener, aside, closing = _some(rng, (0.5, 0.5, 0.4))
    edits: list[str] = []
    if aside:
        a = _choice(rng, filler["asides"])
        commas = [m.start() for m in re.finditer(",", body)]
        if commas and rng.random() < 0.5:
            at = commas[int(rng.integers(0, len(commas)))]
            body = f"{body[:at]}, {a},{body[at + 1:]}"
        else:
            body = f"{body}, {a}"
        edits.append(f"aside {a!r}")
    if opener:
        body = _opened(body, _choice(rng, filler["openers"]), edits)
    return _closed(body, end, _choice(rng, filler["closings"]) if closing else None, edits)


def _neighbours(ch: str) -> str:
    for r, row in enumerate(_KEYBOARD):
        c = row.find(ch)
        if c < 0:
            continue
        near = [row[c - 1] if c > 0 else "", row[c + 1] if c + 1 < len(row) else ""]
        for dr in (-1, 1):
            if 0 <= r + dr < len(_KEYBOARD):
                other = _KEYBOARD[r + dr]
                near.extend(other[k] for k in (c - 1, c) if 0 <= k < len(other))
        return "".join(n for n in near if n)
    return ""


def _typo_word(word: str, rng: np.random.Generator) -> tuple[str, str] | None:
    """One keyboard edit of ``word`` (never its first letter), not a word the generator
    writes; None after 40 tries."""
    known = generator_words()
    low = word.lower()
    for _ in range(40):
        op = _choice(rng, ("substitute", "insert", "delete", "transpose"))
        i = int(rng.integers(1, len(low)))
        if op == "substitute":
            near = _neighbours(low[i])
            if not near:
                continue
            new = low[:i] + _choice(rng, near) + low[i + 1:]
        elif op == "insert":
            near = _neighbours(low[i - 1])
            new = low[:i] + _choice(rng, near) + low[i:]
        elif op == "delete":
            if len(low) < 4:
                continue
            new = low[:i] + low[i + 1:]
        else:
            if i + 1 >= len(low) or low[i] == low[i + 1]:
                continue
            new = low[:i] + low[i + 1] + low[i] + low[i + 2:]
        if new != low and new not in known:
            cased = new.upper() if word.isupper() else (
                _upper_first(new) if word[:1].isupper() else new)
            return cased, op
    return None


def _typo(text: str, rng: np.random.Generator, lex: dict[str, Any]) -> Perturbed:
    targets = set(lex["typo_targets"])
    spots = [m for m in _WORD.finditer(text) if m.group().lower() in targets]
    if not spots:
        return Perturbed(text, False, reason="no colour, shape, relation or verb to misspell")
    n = min(len(spots), 1 + int(rng.random() < 0.5))
    chosen = sorted(rng.choice(len(spots), size=n, replace=False).tolist())
    out, last, edits = [], 0, []
    for k in chosen:
        m = spots[k]
        typo = _typo_word(m.group(), rng)
        if typo is None:
            continue
        new, op = typo
        out.append(text[last:m.start()] + new)
        last = m.end()
        edits.append(f"{op} {m.group()!r} -> {new!r}")
    if not edits:
        return Perturbed(text, False, reason="no edit of its content words avoided a known word")
    return Perturbed("".join(out) + text[last:], True, tuple(edits))


@cache
def _synonym_pattern(words: tuple[str, ...]) -> re.Pattern[str]:
    keys = sorted(words, key=lambda k: (-len(k), k))
    return re.compile(r"\b(" + "|".join(re.escape(k) for k in keys) + r")\b", re.IGNORECASE)


def _synonym(text: str, rng: np.random.Generator, lex: dict[str, Any]) -> Perturbed:
    table: dict[str, list[str]] = lex["synonym"]
    spots = list(_synonym_pattern(tuple(table)).finditer(text))
    if not spots:
        return Perturbed(text, False, reason="no word with a synonym in the suite's lexicon")
    take = rng.random(len(spots)) < 0.6
    if not take.any():
        take[int(rng.integers(0, len(spots)))] = True
    out, last, edits = [], 0, []
    for m, yes in zip(spots, take.tolist(), strict=True):
        if not yes:
            continue
        old = m.group()
        new = _choice(rng, table[old.lower()])
        if old[:1].isupper():
            new = _upper_first(new)
        out.append(text[last:m.start()] + new)
        last = m.end()
        edits.append(f"{old!r} -> {new!r}")
    return Perturbed("".join(out) + text[last:], True, tuple(edits))


def _placeholder_spans(text: str, lexed: str) -> dict[str, tuple[int, int]] | None:
    """Where each ``<S1>``/``<R1>`` ... of the lexed instruction lies in ``text``."""
    parts = re.split(r"(<[SR]\d+>)", lexed)
    if len(parts) < 3:
        return None
    pattern = "".join(
        f"(?P<{p[1:-1]}>.+?)" if re.fullmatch(r"<[SR]\d+>", p) else re.escape(p)
        for p in parts
    )
    try:
        m = re.fullmatch(pattern, text, flags=re.DOTALL)
    except re.error:  # a placeholder written twice: not a lexed form we know
        return None
    if m is None:
        return None
    return {name: m.span(name) for name in m.groupdict()}


def _reorder(text: str, rng: np.random.Generator, lex: dict[str, Any], lexed: str
             ) -> Perturbed:
    spans = _placeholder_spans(text, lexed) if lexed else None
    if spans is None:
        return Perturbed(text, False, reason="no lexed form to find the destination in")
    actions = sorted(lex["reorder_actions"], key=len, reverse=True)
    steps = sorted({int(k[1:]) for k in spans})
    order = [s for s in steps if s == 1] + [s for s in steps if s != 1]
    for k in order:
        if f"S{k}" not in spans or f"R{k}" not in spans:
            continue
        (s0, s1), (r0, r1) = spans[f"S{k}"], spans[f"R{k}"]
        if not s1 < r0:
            continue
        between = text[s1:r0]
        act = next((a for a in actions if between.lower().endswith(" " + a + " ")), None)
        after = text[r1:r1 + 1]
        if act is None or after not in (",", ".", " ", ""):
            continue
        if after == " " and not re.match(r" (and|then)\b", text[r1:]):
            continue
        a0 = r0 - len(act) - 2  # the space before the action phrase
        destination = text[a0 + 1:r1]
        # the clause begins at the text's start (step 1) or after the connector before S
        start = 0 if k == 1 else _clause_start(text, s0)
        if start is None:
            continue
        head = text[start:a0]
        if k == 1:
            new = f"{_upper_first(destination)}, {_lower_first(head)}{text[r1:]}"
        else:
            new = f"{text[:start]}{destination}, {head}{text[r1:]}"
        return Perturbed(new, True, (f"fronted {destination!r} of step {k}",))
    return Perturbed(text, False, reason="no step ends with its destination")


def _clause_start(text: str, subject_start: int) -> int | None:
    """Where the clause holding the subject at ``subject_start`` begins: after the last
    connector (a comma, a full stop, "and" or "then") before it."""
    before = text[:subject_start]
    ms = list(re.finditer(r"(, then|, and then| and then|\. After that,|, after that|"
                          r"\. Next,|\. Then|, and afterwards| and|, and finally|"
                          r"\. Finally,|, and lastly|\. Last,|\. Subsequently,|"
                          r"\. To finish,) ", before))
    if not ms:
        return None
    return ms[-1].end()


_CASE_OPS: Final[tuple[str, ...]] = ("lower", "upper", "no final stop", "exclamation",
                                     "no commas")


def _case_edit(text: str, op: str) -> str:
    if op == "lower":
        return text.lower()
    if op == "upper":
        return text.upper()
    if op == "no final stop":
        return text.rstrip().rstrip(".")
    if op == "exclamation":
        return re.sub(r"\.?\s*$", "!", text.rstrip(), count=1)
    return text.replace(",", "")


def _case(text: str, rng: np.random.Generator, lex: dict[str, Any]) -> Perturbed:
    """One or two of :data:`_CASE_OPS`, in a random order, each one that changes the text
    (lower and upper case always do, unless the text has no letter)."""
    del lex
    want = 1 + int(rng.random() < 0.5)
    out, edits = text, list[str]()
    for k in rng.permutation(len(_CASE_OPS)).tolist():
        op = _CASE_OPS[k]
        if op in ("lower", "upper") and {"lower", "upper"} & set(edits):
            continue
        new = _case_edit(out, op)
        if new != out:
            out = new
            edits.append(op)
        if len(edits) == want:
            break
    if out == text:
        return Perturbed(text, False, reason="no casing or punctuation edit changes it")
    return Perturbed(out, True, tuple(edits))


def _blind(text: str, rng: np.random.Generator, lex: dict[str, Any]) -> Perturbed:
    new = _choice(rng, lex["blind"])
    return Perturbed(new, new != text, ("replaced by a blind instruction",))


_KIND_FUNCTIONS: Final[dict[str, Callable[[str, np.random.Generator, dict[str, Any]],
                                           Perturbed]]] = {
    "filler": _filler, "typo": _typo, "synonym": _synonym,
    "case": _case, "blind": _blind,
}


def perturb_instruction(kind: str, text: str, rng: np.random.Generator, *, lexed: str = "",
                        other: str | None = None, words: str = "test") -> Perturbed:
    """``text`` perturbed by ``kind`` with the word lists ``words`` (:data:`LEXICONS`).
    ``reorder`` needs the episode's lexed instruction (``lexed``: the text with
    ``<S1>``/``<R1>`` ... in place of the references); ``shuffled`` takes the other
    episode's instruction (``other``)."""
    if kind not in KINDS:
        msg = f"perturbation kind {kind!r}; expected one of {list(KINDS)}"
        raise InvalidArgument(msg)
    if not isinstance(text, str) or not text.strip():
        msg = f"instruction {text!r}; expected a non-empty string to perturb"
        raise InvalidArgument(msg)
    lex = lexicon(words)
    if kind == "reorder":
        return _reorder(text, rng, lex, lexed)
    if kind == "polite":
        return _polite(text, rng, lex, lexed)
    if kind == "shuffled":
        if other is None:
            msg = "the shuffled control needs the other episode's instruction (other=)"
            raise InvalidArgument(msg)
        if other == text:
            return Perturbed(text, False, reason="the other episode has the same instruction")
        return Perturbed(other, True, ("another episode's instruction",))
    return _KIND_FUNCTIONS[kind](text, rng, lex)
