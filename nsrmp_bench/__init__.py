"""nsrmp-bench: dataset and benchmark for language-guided robot manipulation."""

from __future__ import annotations

__version__ = "0.1.0"
