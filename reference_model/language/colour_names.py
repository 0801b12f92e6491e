"""Colour names a person may use, read as the world's seven colours.

The names and their RGB values are matplotlib's tables (the 148 CSS4 colours and the 949
of the xkcd colour survey), a well-kept resource that knows nothing of our templates. A
name is read as the world colour nearest in hue (red, yellow, green, cyan, blue, magenta,
as the world renders them), within :data:`MAX_HUE_DEGREES`; a pale, unsaturated name
(ivory, snow) as white; a dark or grey one as no colour.
"""

from __future__ import annotations

import colorsys
from functools import cache
from typing import Final

from nsrmp_bench._optional import require
from nsrmp_bench.vocabulary import COLOUR_RGBA

__all__ = ["MAX_HUE_DEGREES", "colour_of_name"]

MAX_HUE_DEGREES: Final = 30.0
"""A name further than this in hue from every world colour is read as no colour."""
_WHITE_SATURATION: Final = 0.2
_WHITE_VALUE: Final = 0.75
_MIN_SATURATION: Final = 0.35
_MIN_VALUE: Final = 0.3


def _hue(rgb: tuple[float, float, float]) -> tuple[float, float, float]:
    h, s, v = colorsys.rgb_to_hsv(*rgb)
    return h * 360.0, s, v


@cache
def _world_hues() -> dict[str, float]:
    return {name: _hue(rgba[:3])[0] for name, rgba in COLOUR_RGBA.items() if name != "white"}


def _nearest(rgb: tuple[float, float, float]) -> str | None:
    hue, sat, val = _hue(rgb)
    if sat < _WHITE_SATURATION:
        return "white" if val >= _WHITE_VALUE else None
    if sat < _MIN_SATURATION or val < _MIN_VALUE:
        return None
    best, gap = None, MAX_HUE_DEGREES
    for name, h in _world_hues().items():
        d = min(abs(hue - h), 360.0 - abs(hue - h))
        if d <= gap:
            best, gap = name, d
    return best


@cache
def _table() -> dict[str, tuple[float, float, float]]:
    """One-word colour names -> RGB (CSS4 first: where both tables name a colour, the CSS
    one is the plainer sense)."""
    colors = require("matplotlib.colors")

    out: dict[str, tuple[float, float, float]] = {}
    for name, hexa in colors.XKCD_COLORS.items():
        word = name.removeprefix("xkcd:")
        if word.isalpha():
            out[word] = colors.to_rgb(hexa)
    for name, hexa in colors.CSS4_COLORS.items():
        out[name] = colors.to_rgb(hexa)
    return out


def colour_of_name(word: str) -> str | None:
    """The world colour ``word`` names (``crimson`` -> ``red``), or None; also tries the
    word without a trailing ``y`` or ``ish`` (``snowy``, ``reddish``)."""
    table = _table()
    w = word.lower()
    for candidate in (w, w.removesuffix("ish"), w.removesuffix("y"), w.removesuffix("dy")):
        if candidate and candidate in table:
            return _nearest(table[candidate])
    return None
