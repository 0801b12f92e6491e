"""The package's version (``from nsrmp_bench import __version__`` reads it, importing
nothing else); ``pyproject.toml`` states the same (``tests/core/test_release_metadata.py``)."""

from __future__ import annotations

__all__ = ["__version__"]

__version__ = "0.2.0"
