"""NMN+, the paper's attention baseline (``nmn-v1``): train it, load it, predict.

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
from nsrmp_bench.reference_model.nmn.config import NMNConfig
from nsrmp_bench.reference_model.nmn.curriculum import build_stages
from nsrmp_bench.reference_model.nmn.model import NMN, infer
from nsrmp_bench.reference_model.nsrm.inference import (
    Inferred,
    ProgramPredictor,
    inferred_iou_m,
)

__all__ = ["MODEL_ID", "NMNConfig", "NMNPredictor"]

MODEL_ID = "nmn-v1"


class NMNPredictor(ProgramPredictor):
    """NMN+: trains on ``data/train``, selects on ``data/val`` (a split without a val part,
    attributes-v2, selects on the last tenth of its train part, then not trained on);
    predicts from what ``EpisodeDataset`` gives as ``inputs`` only."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NMNConfig
    supervision = ("initial and final boxes only (no gold program, no intermediate "
                   "state, no template id, no reference labels); the single-step stage "
                   "selects episodes by number of steps")
    inputs = "instruction text, initial RGB, initial depth, initial (gold) boxes"
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs_single": 3, "epochs_splitter": 0, "epochs_multistep": 0, "batch_size": 4,
        "splitter_examples": 8}
    config: NMNConfig
    model: NMN

    @classmethod
    def build_network(cls, config: NMNConfig, vocab_size: int,
                      state: Mapping[str, Tensor]) -> NMN:
        return NMN(vocab_size, config)

    @classmethod
    def plan_training(cls, data: Path, config: NMNConfig, seed: int) -> TrainingPlan:
        train, val, vocab = encode_train_val(data)
        model = NMN(len(vocab), config)

        def validate(uses_splitter: bool) -> float:
            return inferred_iou_m(val, infer(model, val, split=uses_splitter))

        return TrainingPlan(
            network=model, stages=build_stages(model, train, config),
            validate=lambda stage: validate(stage.uses_splitter),
            training_data=f"{len(train)} training episodes (train part); selection on val",
            vocab=vocab.to_list())

    def run(self, enc: Encoded) -> Inferred:
        return infer(self.model, enc)
