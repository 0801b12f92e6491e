"""What a leaderboard entry's model card says: training data, time, parameters,
supervision and the inputs the model reads.

The facts come from the card of a registered learned model's shipped checkpoint
(``reference_model/checkpoints/<id>.card.json``) or from the baseline registry (no baseline
is trained); the entry file's own ``"card"`` object overrides them key by key (an outside
submission states its facts there; an entry run from another checkpoint corrects the
training data). A model on a detector's boxes (``nsrm-v1+detector-v1``) has its model's
card, its inputs saying whose boxes it read. Anything else reads "not stated".
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from typing import Any

from nsrmp_bench.baselines.registry import BASELINES
from nsrmp_bench.errors import InvalidArgument

__all__ = ["CARD_FIELDS", "ModelCard", "model_card"]

CARD_FIELDS = (
    ("training_data", "training data"),
    ("training_time", "training time"),
    ("parameters", "parameters"),
    ("supervision", "supervision"),
    ("inputs", "inputs it reads"),
)
"""(key, label) of every fact a card shows, in order."""

NOT_STATED = "not stated"


@dataclass(frozen=True)
class ModelCard:
    """The facts of one model and where they come from."""

    model: str
    facts: dict[str, str]
    source: str


def _checkpoint_card(model: str) -> dict[str, Any] | None:
    try:
        path = resources.files("nsrmp_bench.reference_model").joinpath(
            "checkpoints", f"{model}.card.json")
        text = path.read_text("utf-8")
    except (FileNotFoundError, ModuleNotFoundError, NotADirectoryError):
        return None
    data: dict[str, Any] = json.loads(text)
    return data


def _from_checkpoint(card: dict[str, Any]) -> dict[str, str]:
    time = (f"{float(card['train_seconds']):,.0f} s of training "
            f"({float(card['wall_seconds']):,.0f} s wall) on {card['threads']} CPU threads"
            if "train_seconds" in card else NOT_STATED)
    params = card.get("parameters")
    return {
        "training_data": str(card.get("training_data", NOT_STATED)),
        "training_time": time,
        "parameters": f"{int(params):,}" if params is not None else NOT_STATED,
        "supervision": str(card.get("supervision", NOT_STATED)),
        "inputs": str(card.get("inputs", NOT_STATED)),
    }


def _registered(model: str) -> ModelCard:
    checkpoint = _checkpoint_card(model)
    if checkpoint is not None:
        return ModelCard(model, _from_checkpoint(checkpoint),
                         f"the shipped checkpoint's card ({model}.card.json)")
    if model in BASELINES:
        facts = {"training_data": "none (not trained)", "training_time": "none",
                 "parameters": "0", "supervision": "none",
                 "inputs": BASELINES[model].reads}
        return ModelCard(model, facts, "the baseline registry")
    base, plus, detector = model.partition("+")
    if plus and base and detector:  # a model on a detector's boxes: the model's own card
        card = _registered(base)
        if card.source != "nothing stated":
            facts = {**card.facts,
                     "inputs": f"{card.facts['inputs']}; here the boxes {detector} detected "
                               "instead of the gold boxes"}
            return ModelCard(model, facts, f"{card.source}, for {base} on {detector}'s boxes")
    return ModelCard(model, {k: NOT_STATED for k, _ in CARD_FIELDS}, "nothing stated")


def model_card(model: str, stated: Mapping[str, Any] | None = None) -> ModelCard:
    """The card of ``model``; ``stated`` (the entry file's ``"card"``) overrides its keys."""
    card = _registered(model)
    if not stated:
        return card
    unknown = sorted(set(stated) - {k for k, _ in CARD_FIELDS})
    if unknown:
        msg = (f"model card of {model!r} states unknown facts {unknown}; the facts are "
               f"{[k for k, _ in CARD_FIELDS]}")
        raise InvalidArgument(msg)
    facts = {**card.facts, **{k: str(v) for k, v in stated.items()}}
    source = ("the leaderboard entry" if card.source == "nothing stated"
              else f"the leaderboard entry, then {card.source}")
    return ModelCard(model, facts, source)
