"""One colour and one marker per model id, the same in every figure and on the site.

The colours are Paul Tol's colour-blind-safe *muted* scheme (nine colours), three of
Okabe and Ito's (blue, orange, vermillion), then eight from Tol's *vibrant*, *dark* and
*light* schemes: twenty in all, so every model of a figure has a colour of its own (the
repository ships seventeen). The models the repository ships have fixed places
(:data:`FIXED`), so adding an entry never recolours them; any other model id takes the
first free colour in sorted-id order, and past twenty models the colours repeat with the
next marker, so every model still differs in colour or marker. The reference rows (the
``baseline`` kind: oracle, noop, random) are not coloured series: they are drawn as grey
labelled lines (:data:`REFERENCE_STYLES`).
Needs nothing but the standard library.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

__all__ = [
    "FIXED", "MARKERS", "PALETTE", "REFERENCE_STYLES", "Style", "model_styles", "reference_style",
]

PALETTE = (
    "#332288",  # indigo      (Tol muted)
    "#CC6677",  # rose
    "#117733",  # green
    "#88CCEE",  # cyan
    "#882255",  # wine
    "#44AA99",  # teal
    "#999933",  # olive
    "#AA4499",  # purple
    "#DDCC77",  # sand
    "#0072B2",  # blue        (Okabe-Ito)
    "#E69F00",  # orange
    "#D55E00",  # vermillion
    "#EE3377",  # magenta     (Tol vibrant)
    "#CC3311",  # red
    "#225555",  # dark teal   (Tol dark)
    "#663333",  # brown
    "#666633",  # dark olive
    "#77AADD",  # light blue  (Tol light)
    "#BBCC33",  # pear
    "#FFAABB",  # pink
)
"""Twenty colours, colour-blind-safe schemes first."""

MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "p", "h", "*", "d", "H", "8", "o",
           "s", "^", "D", "v")
"""Matplotlib markers, one per palette place (the site shows the colour only)."""

FIXED = {
    "nsrm-v1": 0,
    "nmn-v1": 1,
    "dense-v1": 2,
    "dense5x-v1": 3,
    "nsrm-v1+detector-v1": 4,
    "nmn-v1+detector-v1": 5,
    "nsrm-v1+classical-v1": 6,
    "nmn-v1+classical-v1": 7,
    "dense-v2": 8,
    "dense5x-v2": 9,
    "nmn-v2": 10,
    "nsrm-v2": 11,
    "nsrm-v2+classical-v1": 12,
}
"""Palette places of the models the repository ships."""


@dataclass(frozen=True)
class Style:
    """How one model is drawn."""

    colour: str
    marker: str
    linestyle: str = "-"


REFERENCE_STYLES: Mapping[str, Style] = {
    "oracle-v1": Style("#222222", "", "--"),
    "noop-v1": Style("#555555", "", ":"),
    "random-v1": Style("#888888", "", "-."),
}
"""The reference rows' grey lines (any other reference model: the last one's style)."""


def reference_style(model: str) -> Style:
    """The grey line of a reference row."""
    return REFERENCE_STYLES.get(model, Style("#888888", "", ":"))


def model_styles(models: Iterable[str]) -> dict[str, Style]:
    """The style of every model id in ``models`` (fixed places first, the rest sorted)."""
    wanted = sorted(set(models))
    places: dict[str, int] = {m: FIXED[m] for m in wanted if m in FIXED}
    taken = set(places.values())
    free = (i for i in range(10 * len(PALETTE)) if i % len(PALETTE) not in taken
            or i >= len(PALETTE))
    for model in wanted:
        if model not in places:
            places[model] = next(free)
    out = {}
    for model, place in places.items():
        colour = PALETTE[place % len(PALETTE)]
        marker = MARKERS[(place + place // len(PALETTE)) % len(MARKERS)]
        out[model] = Style(colour, marker)
    return out
