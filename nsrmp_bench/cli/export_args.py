"""The arguments the export verbs share (``export-hf``, ``export-lerobot``): a split (or
one part) and a new or empty output folder."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_arguments"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of an export verb."""
    parser.add_argument("data", type=Path, help="a generated split directory (or one part)")
    parser.add_argument("--out", type=Path, required=True, help="a new or empty folder")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
