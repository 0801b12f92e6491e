"""The learned models by id (``name-vN``): how to train one and how to load one.

Adding a model is adding a sub-package and one entry here. Everything imports lazily, so
listing the models needs no torch.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench.versioned_ids import resolve_id

__all__ = ["MODELS", "ModelEntry", "get_model", "load_model"]


@dataclass(frozen=True)
class ModelEntry:
    """A registered learned model."""

    id: str
    description: str
    module: str  # sub-package with train_<name>(...) and a <Name>Predictor class
    trainer: str
    predictor: str
    config: str  # the config dataclass in ``module`` (``train --set`` overrides its fields)
    label: str = ""  # said beside the id wherever its results are shown (e.g. "not CLIPort")

    def train_fn(self) -> Callable[..., Path]:
        """The training entry point."""
        fn: Callable[..., Path] = getattr(importlib.import_module(self.module), self.trainer)
        return fn

    def config_cls(self) -> Callable[[], Any]:
        """The model's config dataclass (its defaults are the shipped run's settings)."""
        cls: Callable[[], Any] = getattr(importlib.import_module(self.module), self.config)
        return cls

    def predictor_cls(self) -> Callable[[Path], Any]:
        """The class that loads a checkpoint and predicts."""
        cls: Callable[[Path], Any] = getattr(importlib.import_module(self.module),
                                             self.predictor)
        return cls


MODELS: dict[str, ModelEntry] = {
    m.id: m
    for m in (
        ModelEntry("nsrm-v1", "neuro-symbolic reference model (gold boxes), learnt from "
                   "initial and final scenes", "nsrmp_bench.reference_model.nsrm",
                   "train_nsrm", "NSRMPredictor", "NSRMConfig"),
        ModelEntry("reconstruction-v1", "scene reconstruction: the image after each "
                   "predicted step from the image before it and the moved boxes (U-Net)",
                   "nsrmp_bench.reference_model.reconstruction", "train_reconstruction",
                   "ReconstructionPredictor", "ReconstructionConfig"),
        ModelEntry("dense-v1", "dense baseline, not CLIPort: a from-scratch two-stream FCN "
                   "from RGB-D and the instruction to pick and place heatmaps, trained on "
                   "paper-v2/train's single-step episodes", "nsrmp_bench.reference_model.dense",
                   "train_dense", "DensePredictor", "DenseConfig", "not CLIPort"),
        ModelEntry("dense5x-v1", "dense baseline, not CLIPort, on 5x the data "
                   "(dense5x-v2/train, selected on paper-v2/val)",
                   "nsrmp_bench.reference_model.dense", "train_dense5x", "Dense5xPredictor",
                   "Dense5xConfig", "not CLIPort, 5x data"),
        ModelEntry("detector-v1", "CenterNet-style object detector (RGB and height above the "
                   "table), from scratch; writes detections, not predictions",
                   "nsrmp_bench.reference_model.detector", "train_detector",
                   "DetectorPredictor", "DetectorConfig"),
        ModelEntry("nmn-v1", "NMN+ attention baseline (gold boxes, box coordinates in the "
                   "object features), learnt from initial and final scenes",
                   "nsrmp_bench.reference_model.nmn", "train_nmn", "NMNPredictor",
                   "NMNConfig"),
        ModelEntry("nsrm-v2", "neuro-symbolic reference model v2 (gold boxes): words as "
                   "concepts, a role parser, relations on the current state, a splitter "
                   "and a 3D action rule, learnt from initial and final boxes",
                   "nsrmp_bench.reference_model.nsrm2", "train_nsrm2", "NSRM2Predictor",
                   "NSRM2Config"),
        ModelEntry("nmn-v2", "NMN+ attention baseline v2 (gold boxes) on NSRM v2's "
                   "perception, splitter, action rule and training: attention in place of "
                   "the program", "nsrmp_bench.reference_model.nmn2", "train_nmn2",
                   "NMN2Predictor", "NMN2Config"),
    )
}


def get_model(name: str) -> ModelEntry:
    """The model ``name``: an id, or a bare name meaning its latest version."""
    return MODELS[resolve_id(name, MODELS, "model")]


def load_model(name: str, checkpoint: str | Path | None = None) -> Any:
    """A loaded model ready to predict: the shipped checkpoint unless one is given."""
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint

    entry = get_model(name)
    path = Path(checkpoint) if checkpoint is not None else shipped_checkpoint(entry.id)
    return entry.predictor_cls()(path)
