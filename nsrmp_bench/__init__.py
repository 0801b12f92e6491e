"""nsrmp-bench: dataset and benchmark for language-guided robot manipulation."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # type checkers see the real signature; at run time it is lazy
    from nsrmp_bench.reference_model.registry import load_model as load_model
    from nsrmp_bench.scoring.scorer import score as score
    from nsrmp_bench.storage.reader import open as open

__version__ = "0.2.0"

__all__ = ["__version__", "load_model", "open", "score"]
"""The top-level names: ``open`` (read data), ``score`` (score predictions) and
``load_model`` (a learned model; the torch extra), imported on first use."""

if "gymnasium" in sys.modules:
    # ``import gymnasium; import nsrmp_bench`` registers nsrmp_bench/Tabletop-v0, so
    # ``gymnasium.register_envs(nsrmp_bench)`` works as for other environment packages.
    # Importing Gymnasium only for this would cost every import ~0.3 s; without it, use
    # ``import nsrmp_bench.envs`` or the id "nsrmp_bench.envs:nsrmp_bench/Tabletop-v0".
    from nsrmp_bench.envs import register_envs as _register_envs

    _register_envs()


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


def __dir__() -> list[str]:
    """The lazy exports too (``dir(nsrmp_bench)``, tab completion)."""
    return sorted({*__all__, *(n for n in globals() if n.startswith("__"))})
