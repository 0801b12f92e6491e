"""Which protocol an entry was scored under, and which rows are references.

Three protocols share a board, and a reader must see which one a row used:

* **gold boxes**: the model read the episode's initial gold boxes (the paper's setting);
* **detected boxes**: the model read boxes a detector extracted from the image and the
  scorer matched them to the gold objects (``SCORING.md``, the detected-objects protocol);
  the detector is named after the ``+`` of the model id (``nsrm-v1+detector-v1``);
* **dense**: the predictions give only pick and place pixels (no program, no positions),
  as the dense baseline writes them.

The protocol is read from the scorer's own counts of the predictions file (lines in the
detected-objects protocol; lines with a program or positions), not from the entry's
wording, so a submission cannot mislabel itself. The *reference* rows are the registered
baselines (kind ``baseline``: oracle, noop, random): bounds, not competitors; they are
drawn as labelled lines and are not ranked.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from nsrmp_bench.ranks import is_reference

__all__ = ["DENSE", "DETECTED", "GOLD", "PROTOCOLS", "Protocol", "is_reference", "protocol_of"]

GOLD = "gold boxes"
DETECTED = "detected boxes"
DENSE = "dense"
PROTOCOLS = (GOLD, DETECTED, DENSE)
"""The protocols, in the order figures and filters show them."""

@dataclass(frozen=True)
class Protocol:
    """A row's protocol and, for detected boxes, the detector."""

    name: str
    detector: str | None = None

    @property
    def label(self) -> str:
        """What the site's protocol column says."""
        if self.name == DETECTED:
            return f"{DETECTED} ({self.detector or 'detector not named'})"
        return self.name


def protocol_of(model: str, counts: Mapping[str, int]) -> Protocol:
    """The protocol of a scored run of ``model`` from the scorer's ``counts``."""
    if int(counts.get("detected_lines", 0)) > 0:
        detector = model.split("+", 1)[1] if "+" in model else None
        return Protocol(DETECTED, detector)
    lines = int(counts.get("lines", 0))
    if lines > 0 and not counts.get("with_program") and not counts.get("with_positions") \
            and not counts.get("with_step_boxes"):
        return Protocol(DENSE)
    return Protocol(GOLD)

