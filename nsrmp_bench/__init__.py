"""nsrmp-bench: dataset and benchmark for language-guided robot manipulation."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # type checkers see the real signature; at run time it is lazy
    from nsrmp_bench.reference_model.registry import load_model as load_model
    from nsrmp_bench.scoring.scorer import score as score
    from nsrmp_bench.storage.reader import open as open

__version__ = "0.1.0"


def __getattr__(name: str) -> object:
    """Lazy re-exports: ``nsrmp_bench.open`` imports the storage reader on first use."""
    if name == "open":
        from nsrmp_bench.storage.reader import open as open_episodes

        return open_episodes
    if name == "load_model":  # the learned models (torch extra)
        from nsrmp_bench.reference_model.registry import load_model

        return load_model
    if name == "score":
        from nsrmp_bench.scoring.scorer import score

        return score
    msg = f"module 'nsrmp_bench' has no attribute {name!r}"
    raise AttributeError(msg)
