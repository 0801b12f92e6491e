"""NSRM, the neuro-symbolic reference model (``nsrm-v1``): train it, load it, predict.

See ``MODEL_CARD.md`` beside this file for what it reads, how it is supervised and how it
is trained.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import ClassVar

from torch import Tensor

from nsrmp_bench.reference_model.base import TrainingPlan
from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.encoded import Encoded, encode_train_val
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig
from nsrmp_bench.reference_model.nsrm.curriculum import build_stages
from nsrmp_bench.reference_model.nsrm.inference import (
    Inferred,
    ProgramPredictor,
    infer,
    inferred_iou_m,
)
from nsrmp_bench.reference_model.nsrm.model import NSRM

__all__ = ["MODEL_ID", "NSRMConfig", "NSRMPredictor", "val_iou_m"]

MODEL_ID = "nsrm-v1"


def val_iou_m(model: NSRM, enc: Encoded, split: bool = True) -> float:
    """The in-loop validation IoU-M (:func:`~.inference.inferred_iou_m`) of ``model``."""
    return inferred_iou_m(enc, infer(model, enc, split=split))


class NSRMPredictor(ProgramPredictor):
    """NSRM: trains on ``data/train``, selects on ``data/val`` (a split without a val part,
    attributes-v2, selects on the last tenth of its train part, then not trained on);
    predicts from what ``EpisodeDataset`` gives as ``inputs`` only."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NSRMConfig
    supervision = ("initial and final boxes only (no gold program, no intermediate "
                   "state, no template id, no lexed slots, no reference labels); the "
                   "curriculum selects episodes by number of steps and relational flag")
    inputs = "instruction text, initial RGB, initial depth, initial (gold) boxes"
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs_attribute": 3, "epochs_relational": 0, "epochs_reinforce": 0,
        "epochs_splitter": 0, "epochs_multistep": 0, "batch_size": 4, "splitter_examples": 8}
    config: NSRMConfig
    model: NSRM

    @classmethod
    def build_network(cls, config: NSRMConfig, vocab_size: int,
                      state: Mapping[str, Tensor]) -> NSRM:
        return NSRM(vocab_size, config)

    @classmethod
    def plan_training(cls, data: Path, config: NSRMConfig, seed: int) -> TrainingPlan:
        train, val, vocab = encode_train_val(data)
        model = NSRM(len(vocab), config)
        return TrainingPlan(
            network=model, stages=build_stages(model, train, config),
            validate=lambda stage: val_iou_m(model, val, stage.uses_splitter),
            training_data=f"{len(train)} training episodes (train part); selection on val",
            vocab=vocab.to_list())

    def run(self, enc: Encoded) -> Inferred:
        return infer(self.model, enc)
