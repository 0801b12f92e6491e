"""nsrmp-bench: dataset and benchmark for language-guided robot manipulation.

The package root is the users' front door and nothing else: ``__version__`` (from
:mod:`nsrmp_bench._version`: ``from nsrmp_bench import __version__`` imports no other
module) and four names imported on first use: ``open`` (read data,
:func:`nsrmp_bench.storage.reader.open`), ``score`` (score predictions,
:func:`nsrmp_bench.scoring.scorer.score`), ``load_model`` (a learned model, the torch
extra: :func:`nsrmp_bench.reference_model.registry.load_model`) and ``serve`` (serve a
policy for ``rollout --server``, the serve extra: :func:`nsrmp_bench.serving.server.serve`).
No module of the package imports the root (``tests/core/test_import_graph.py``), so these
names put no arrow between the layers. The Gymnasium environment registers when
:mod:`nsrmp_bench.envs` is imported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nsrmp_bench._version import __version__

if TYPE_CHECKING:  # type checkers see the real signature; at run time it is lazy
    from nsrmp_bench.reference_model.registry import load_model as load_model
    from nsrmp_bench.scoring.scorer import score as score
    from nsrmp_bench.serving.server import serve as serve
    from nsrmp_bench.storage.reader import open as open

__all__ = ["__version__", "load_model", "open", "score", "serve"]
"""The top-level names: ``open`` (read data), ``score`` (score predictions),
``load_model`` (a learned model; the torch extra) and ``serve`` (a policy server; the
serve extra), imported on first use."""


def __getattr__(name: str) -> object:
    """Names imported on first use: ``nsrmp_bench.open`` imports the storage reader then."""
    if name == "open":
        from nsrmp_bench.storage.reader import open as open_episodes

        return open_episodes
    if name == "load_model":  # the learned models (torch extra)
        from nsrmp_bench.reference_model.registry import load_model

        return load_model
    if name == "score":
        from nsrmp_bench.scoring.scorer import score

        return score
    if name == "serve":  # the policy server (serve extra)
        from nsrmp_bench.serving.server import serve

        return serve
    msg = f"module 'nsrmp_bench' has no attribute {name!r}"
    raise AttributeError(msg)


def __dir__() -> list[str]:
    """The names imported on first use too (``dir(nsrmp_bench)``, tab completion)."""
    return sorted({*__all__, *(n for n in globals() if n.startswith("__"))})
