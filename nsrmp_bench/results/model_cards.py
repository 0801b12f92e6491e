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
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from nsrmp_bench.baselines.registry import BASELINES
from nsrmp_bench.errors import InvalidArgument

__all__ = ["CARD_FIELDS", "ModelCard", "TrainingCard", "model_card", "read_training_card",
           "shipped_label", "write_training_card"]

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


@dataclass(frozen=True)
class TrainingCard:
    """The card a training run writes (``card.json`` beside ``best.pt``): one type for every
    learned model, written by :func:`write_training_card` only."""

    model: str
    training_data: str
    train_seconds: float
    wall_seconds: float
    parameters: int
    seed: int
    threads: int
    supervision: str
    inputs: str
    score_name: str  # the validation score best.pt was selected on ("val IoU-M")
    best_score: float
    config: dict[str, Any] = field(default_factory=dict)
    label: str = ""
    read_seconds: float | None = None  # reading the data, when stated apart

    def to_json(self) -> dict[str, Any]:
        """The JSON object (``label`` and ``read_seconds`` only when stated)."""
        data = asdict(self)
        if not self.label:
            del data["label"]
        if self.read_seconds is None:
            del data["read_seconds"]
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> TrainingCard:
        """A card from its JSON; the cards shipped before this type (``best_val_<score>``
        and per-model timing keys) read too."""
        best = data.get("best_score")
        score = data.get("score_name")
        if best is None:
            olds = [k for k in data if k.startswith("best_val_")]
            score = olds[0].removeprefix("best_") if olds else "not stated"
            best = data[olds[0]] if olds else float("nan")
        read = data.get("read_seconds", data.get("load_seconds"))
        try:
            return cls(
                model=str(data["model"]), training_data=str(data["training_data"]),
                train_seconds=float(data["train_seconds"]),
                wall_seconds=float(data["wall_seconds"]), parameters=int(data["parameters"]),
                seed=int(data["seed"]), threads=int(data["threads"]),
                supervision=str(data["supervision"]), inputs=str(data["inputs"]),
                score_name=str(score), best_score=float(best),
                config=dict(data.get("config", {})), label=str(data.get("label", "")),
                read_seconds=None if read is None else float(read))
        except KeyError as exc:
            msg = (f"model card of {data.get('model', '?')!r} lacks {exc.args[0]!r}; a "
                   "training run writes every fact (retrain, or state it in the entry)")
            raise InvalidArgument(msg) from exc


def write_training_card(path: Path, card: TrainingCard) -> Path:
    """Write ``card`` as sorted, indented JSON, atomically."""
    from nsrmp_bench.storage.records import atomic_write_text

    atomic_write_text(path, json.dumps(card.to_json(), indent=1, sort_keys=True) + "\n")
    return path


def read_training_card(path: Path) -> TrainingCard:
    """The card of a training run (``card.json``) or a shipped ``<id>.card.json``."""
    return TrainingCard.from_json(json.loads(Path(path).read_text("utf-8")))


def _checkpoint_card(model: str) -> dict[str, Any] | None:
    try:
        path = resources.files("nsrmp_bench.reference_model").joinpath(
            "checkpoints", f"{model}.card.json")
        text = path.read_text("utf-8")
    except (FileNotFoundError, ModuleNotFoundError, NotADirectoryError):
        return None
    data: dict[str, Any] = json.loads(text)
    return data


def shipped_label(model: str) -> str:
    """The label said beside a learned model's id (``not CLIPort``), from its shipped card;
    empty if it has none."""
    card = _checkpoint_card(model)
    return str(card.get("label", "")) if card is not None else ""


def _from_checkpoint(data: dict[str, Any]) -> dict[str, str]:
    card = TrainingCard.from_json(data)
    return {
        "training_data": card.training_data,
        "training_time": (f"{card.train_seconds:,.0f} s of training "
                          f"({card.wall_seconds:,.0f} s wall) on {card.threads} CPU threads"),
        "parameters": f"{card.parameters:,}",
        "supervision": card.supervision,
        "inputs": card.inputs,
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
