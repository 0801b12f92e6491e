"""A toy learned model that exists only to show the contract: its folder (this file) and
one :func:`~nsrmp_bench.reference_model.registry.register` call are all it takes for the
contract tests (``tests/models/test_contract.py``) to train, load and run it.

It reads the initial boxes, scores each object with a small MLP on its box, and predicts
the top object as picked and placed where it is (a dense-kind model: pick and place, no
program). Supervision: which object the first step moves.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import torch
from torch import Tensor, nn

from nsrmp_bench.dataset import EpisodeDataset
from nsrmp_bench.reference_model.base import PredictionModel, TrainingPlan
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.training import Stage
from nsrmp_bench.scoring.submission import Prediction

MODEL_ID = "toy-v1"


@dataclass(frozen=True)
class ToyConfig(ModelConfig):
    """The toy's sizes and optimisation."""

    hidden: int = 16
    epochs: int = 4
    batch_size: int = 4
    lr: float = 0.02
    threads: int = 1

    def validate(self) -> None:
        super().validate()
        self.require(self.hidden > 0, "hidden", "must be positive")


class ToyNet(nn.Module):
    """Per-object scores from the object's box (normalised by the image size)."""

    def __init__(self, hidden: int) -> None:
        super().__init__()
        self.mlp = nn.Sequential(nn.Linear(4, hidden), nn.ReLU(), nn.Linear(hidden, 1))

    def forward(self, boxes: Tensor, mask: Tensor) -> Tensor:
        scores: Tensor = self.mlp(boxes / 320.0).squeeze(-1)
        return scores.masked_fill(~mask, -1e9)


def _boxes(items: Sequence[Mapping[str, Any]]) -> tuple[Tensor, Tensor]:
    n = max(len(it["inputs"]["boxes"]) for it in items)
    boxes = torch.zeros(len(items), n, 4)
    mask = torch.zeros(len(items), n, dtype=torch.bool)
    for i, it in enumerate(items):
        b = it["inputs"]["boxes"].float()
        boxes[i, : len(b)], mask[i, : len(b)] = b, True
    return boxes, mask


class ToyModel(PredictionModel):
    """The toy (see the module)."""

    model_id = MODEL_ID
    kind = Kind.DENSE
    config_cls: ClassVar[type[ModelConfig]] = ToyConfig
    supervision = "the first step's moved object"
    inputs = "initial boxes"
    tiny_overrides: ClassVar[dict[str, object]] = {}
    config: ToyConfig
    model: ToyNet

    @classmethod
    def build_network(cls, config: ToyConfig, vocab_size: int,
                      state: Mapping[str, Tensor]) -> ToyNet:
        return ToyNet(config.hidden)

    @classmethod
    def plan_training(cls, data: Path, config: ToyConfig, seed: int) -> TrainingPlan:
        ds = EpisodeDataset(data / "train", images=False)
        items = [ds[i] for i in range(len(ds))]
        boxes, mask = _boxes(items)
        moved = torch.tensor([int(it["targets"]["grounded"][0, 1]) for it in items])
        net = ToyNet(config.hidden)

        def step(rows: Tensor) -> Tensor:
            return nn.functional.cross_entropy(net(boxes[rows], mask[rows]), moved[rows])

        def validate(stage: Stage) -> float:
            with torch.no_grad():
                return float((net(boxes, mask).argmax(1) == moved).float().mean())

        stage = Stage("toy", config.epochs, torch.arange(len(items)),
                      lambda: list(net.parameters()), step, config.lr, config.batch_size,
                      uses_splitter=True)
        return TrainingPlan(network=net, stages=[stage], validate=validate,
                            training_data=f"{len(items)} episodes of {data / 'train'}",
                            score_name="val accuracy")

    def predict(self, items: Sequence[dict[str, Any]]) -> Iterator[Prediction]:
        self.set_threads()
        boxes, mask = _boxes(items)
        with torch.no_grad():
            top = self.model(boxes, mask).argmax(1).tolist()
        for it, k in zip(items, top, strict=True):
            b = it["inputs"]["boxes"].double().numpy()
            cx, cy = float(b[k, 0] + b[k, 2]) / 2, float(b[k, 1] + b[k, 3]) / 2
            yield Prediction(id=str(it["id"]), boxes=b, pick=(cx, cy), place=(cx, cy))
