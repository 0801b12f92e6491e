"""The tokeniser and vocabulary every learned model shares.

Instructions are lower-cased and split into words and the punctuation ``,`` and ``.``;
the vocabulary is built from the training instructions only (``<pad>`` = 0, ``<unk>`` = 1),
so a word first seen at test time (a held-out synonym) reads as ``<unk>``. Which word
means which concept is left to the models to learn: nothing here knows the templates.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = ["PAD", "UNK", "Vocabulary", "tokenise"]

PAD = 0
UNK = 1
_TOKEN = re.compile(r"[a-z]+|[.,]")


def tokenise(text: str) -> list[str]:
    """Lower-cased words and ``,``/``.`` of ``text``, in order."""
    return _TOKEN.findall(text.lower())


@dataclass(frozen=True)
class Vocabulary:
    """Word <-> id; ids 0 and 1 are ``<pad>`` and ``<unk>``."""

    words: tuple[str, ...]

    @classmethod
    def build(cls, texts: Iterable[str], min_count: int = 1) -> Vocabulary:
        """The vocabulary of ``texts`` (words seen at least ``min_count`` times, sorted)."""
        counts = Counter(w for t in texts for w in tokenise(t))
        kept = sorted(w for w, c in counts.items() if c >= min_count)
        return cls(("<pad>", "<unk>", *kept))

    def __len__(self) -> int:
        return len(self.words)

    def encode(self, text: str) -> list[int]:
        """Token ids of ``text`` (unknown words -> ``UNK``)."""
        index = self._index
        return [index.get(w, UNK) for w in tokenise(text)]

    def decode(self, ids: Sequence[int]) -> list[str]:
        """The words of ``ids`` (padding dropped)."""
        return [self.words[i] for i in ids if i != PAD]

    @property
    def _index(self) -> dict[str, int]:
        cached: dict[str, int] | None = self.__dict__.get("_cache")
        if cached is None:
            cached = {w: i for i, w in enumerate(self.words)}
            object.__setattr__(self, "_cache", cached)
        return cached

    def to_list(self) -> list[str]:
        """JSON-able form (stored in checkpoints)."""
        return list(self.words)
