"""Whole-number options checked when the command line is read (``type=positive_int``).

A bad value then ends in argparse's one line naming the option (``argument --shard-size:
expected a whole number >= 1, got '0'``), before any folder is made or any work started.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

__all__ = ["non_negative_int", "positive_int"]


def _at_least(low: int, name: str) -> Callable[[str], int]:
    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = low - 1
        if value < low or str(value) != text.strip().lstrip("+"):
            msg = f"expected a whole number >= {low}, got {text!r}"
            raise argparse.ArgumentTypeError(msg)
        return value

    convert.__name__ = name
    return convert


positive_int = _at_least(1, "positive whole number")
"""``type=`` of counts and sizes (workers, shard size, limit)."""
non_negative_int = _at_least(0, "whole number")
"""``type=`` of seeds, indices and resample counts."""
