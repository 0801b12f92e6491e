"""The learned models by id (``name-vN``): one :class:`ModelEntry` each.

Adding a model is adding its sub-package (a :class:`~.base.LearnedModel` subclass with its
config, network, loss and inference) and one entry here (or, outside the package,
:func:`register`). An entry names the model's class as ``module:Class`` and everything
imports lazily, so listing the models and their kinds needs no torch. :func:`register`
puts the entry in the one registry of predictors too (:data:`nsrmp_bench.predictors.PREDICTORS`,
beside the baselines), from which ``predict``, the boards and the closed loop's policies
follow by the entry's kind. The wheel finds a new sub-package by itself (``setup.py``
discovers every package under ``reference_model/``).

A superseded model whose code has left the package is a
:class:`~nsrmp_bench.predictors.RetiredPredictor` here (the v1 models: ``nsrm-v1``,
``nmn-v1``, ``dense-v1``, ``dense5x-v1``): not in :data:`MODELS`, but its id, kind,
description and label stay registered for the committed predictions, cards and board rows
that name it, and :func:`get_model` (so ``train``, ``predict``, ``load_model``) refuses it,
naming the release that still runs it and the version that replaces it.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.predictors import RetiredPredictor, refuse_retired, register_predictor
from nsrmp_bench.reference_model.contract import Kind
from nsrmp_bench.versioned_ids import resolve_id

if TYPE_CHECKING:
    from nsrmp_bench.reference_model.base import LearnedModel, PredictionModel
    from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["MODELS", "ModelEntry", "get_model", "load_model", "load_predictor", "register"]

@dataclass(frozen=True)
class ModelEntry:
    """A registered learned model."""

    id: str
    kind: Kind
    description: str
    model: str  # its LearnedModel subclass, "package.module:Class"
    label: str = ""  # said beside the id wherever its results are shown (e.g. "not CLIPort")

    def model_cls(self) -> type[LearnedModel]:
        """The model's class (imports it: needs torch)."""
        from nsrmp_bench._optional import require
        from nsrmp_bench.reference_model.base import LearnedModel

        require("torch")
        module, _, name = self.model.partition(":")
        cls = getattr(importlib.import_module(module), name)
        if not (isinstance(cls, type) and issubclass(cls, LearnedModel)):
            msg = f"{self.model} is not a LearnedModel subclass (model {self.id})"
            raise TypeError(msg)
        if cls.model_id != self.id or cls.kind is not self.kind:
            msg = (f"{self.model} says it is {cls.model_id} ({cls.kind.value}) but is "
                   f"registered as {self.id} ({self.kind.value})")
            raise TypeError(msg)
        return cls

    def config_cls(self) -> type[ModelConfig]:
        """The model's config dataclass (its defaults are the shipped run's settings)."""
        return self.model_cls().config_cls

    @property
    def name(self) -> str:
        """The id without its version (``nsrm`` of ``nsrm-v3``)."""
        return self.id.rsplit("-v", 1)[0]


MODELS: dict[str, ModelEntry] = {}


def register(entry: ModelEntry) -> ModelEntry:
    """Add ``entry`` to :data:`MODELS` and to the predictors of
    :mod:`nsrmp_bench.predictors` (an id registered twice is an error)."""
    if entry.id in MODELS and MODELS[entry.id] != entry:
        msg = f"model id {entry.id!r} is registered already; give the new model a new id"
        raise InvalidArgument(msg)
    if entry.kind is Kind.BASELINE:
        msg = (f"model {entry.id!r} is registered with kind baseline; a learned model is a "
               "program, dense, detector or reconstruction model")
        raise InvalidArgument(msg)
    register_predictor(entry)
    MODELS[entry.id] = entry
    return entry


_HERE = "nsrmp_bench.reference_model"

for _entry in (
    ModelEntry("reconstruction-v1", Kind.RECONSTRUCTION, "scene reconstruction: the image "
               "after each predicted step from the image before it and the moved boxes "
               "(U-Net)", f"{_HERE}.reconstruction:ReconstructionPredictor"),
    ModelEntry("dense-v2", Kind.DENSE, "dense baseline v2, not CLIPort: dense-v1's "
               "language-conditioned pick stream and a Transporter transport for the place "
               "(pick-centred crop features cross-correlated with the scene's), trained on "
               "paper-v2/train's single-step episodes", f"{_HERE}.dense:DenseV2Predictor",
               "not CLIPort"),
    ModelEntry("dense5x-v2", Kind.DENSE, "dense baseline v2, not CLIPort, on 5x the data: "
               "dense-v2's network trained for the same epochs on dense5x-v2/train "
               "(selected on paper-v2/val)", f"{_HERE}.dense:Dense5xV2Predictor",
               "not CLIPort, 5x data"),
    ModelEntry("detector-v1", Kind.DETECTOR, "CenterNet-style object detector (RGB and height "
               "above the table), from scratch; writes detections, not predictions",
               f"{_HERE}.detector:DetectorPredictor"),
    ModelEntry("nsrm-v2", Kind.PROGRAM, "neuro-symbolic reference model v2 (gold boxes): "
               "words as concepts, a role parser, relations on the current state, a "
               "splitter and a 3D action rule, learnt from initial and final boxes",
               f"{_HERE}.nsrm2:NSRM2Model"),
    ModelEntry("nmn-v2", Kind.PROGRAM, "NMN+ attention baseline v2 (gold boxes) on NSRM v2's "
               "perception, splitter, action rule and training: attention in place of the "
               "program", f"{_HERE}.nmn2:NMN2Model"),
    ModelEntry("nsrm-v3", Kind.PROGRAM, "neuro-symbolic reference model v3 (gold boxes): "
               "NSRM v2's networks reading what a person says through the language front "
               "end (colour names, typos, words it never saw dropped, sentences that name no "
               "object ignored, fronted destinations put back, spatial phrases such as "
               "\"above\" read as the world's actions)", f"{_HERE}.nsrm3:NSRM3Model"),
    ModelEntry("nmn-v3", Kind.PROGRAM, "NMN+ attention baseline v3 (gold boxes): NMN+ v2's "
               "networks behind NSRM v3's language front end", f"{_HERE}.nmn3:NMN3Model"),
    ModelEntry("nsrm-v4", Kind.PROGRAM, "neuro-symbolic reference model v4 (gold boxes): "
               "NSRM v3's networks and front end behind a reader of sentence structure "
               "(steps where actions begin, constraints, questions and prohibitions as no "
               "action, self-corrections, ellipsis, superlatives as extreme, and abstaining "
               "where a referent is absent or ambiguous)", f"{_HERE}.nsrm4:NSRM4Model"),
    ModelEntry("nmn-v4", Kind.PROGRAM, "NMN+ attention baseline v4 (gold boxes): NMN+ v3's "
               "networks behind NSRM v4's reader of sentence structure",
               f"{_HERE}.nmn4:NMN4Model"),
):
    register(_entry)

_V1_RELEASE = "0.2.0"  # the last release with the v1 models' code and checkpoints

for _retired in (
    RetiredPredictor("nsrm-v1", Kind.PROGRAM, "neuro-symbolic reference model (gold boxes), "
                     "learnt from initial and final scenes", _V1_RELEASE, "nsrm-v4"),
    RetiredPredictor("nmn-v1", Kind.PROGRAM, "NMN+ attention baseline (gold boxes, box "
                     "coordinates in the object features), learnt from initial and final "
                     "scenes", _V1_RELEASE, "nmn-v4"),
    RetiredPredictor("dense-v1", Kind.DENSE, "dense baseline, not CLIPort: a from-scratch "
                     "two-stream FCN from RGB-D and the instruction to pick and place "
                     "heatmaps, trained on paper-v2/train's single-step episodes",
                     _V1_RELEASE, "dense-v2", "not CLIPort"),
    RetiredPredictor("dense5x-v1", Kind.DENSE, "dense baseline, not CLIPort, on 5x the data "
                     "(dense5x-v2/train, selected on paper-v2/val)", _V1_RELEASE,
                     "dense5x-v2", "not CLIPort, 5x data"),
):
    register_predictor(_retired)


def get_model(name: str) -> ModelEntry:
    """The model ``name``: an id, or a bare name meaning its latest version; a retired id
    (``nsrm-v1``) is an :class:`InvalidArgument` naming the release that runs it."""
    refuse_retired(name)
    return MODELS[resolve_id(name, MODELS, "model")]


def load_model(name: str, checkpoint: str | Path | None = None) -> LearnedModel:
    """A loaded model ready for inference: the shipped checkpoint unless one is given.

    ``name`` is an id (``nsrm-v3``) or a bare name (``nsrm``, its latest version). What the
    model runs depends on its ``kind``: program and dense models are
    :class:`~.base.PredictionModel` (``predict(items)``; see :func:`load_predictor`), the
    detector has ``detect(items)`` and ``detect_part(data)``, the reconstruction network
    ``reconstruct(item, step_boxes)`` and ``chain(...)``; items are ``EpisodeDataset``'s."""
    entry = get_model(name)  # an unknown or retired id is said before torch is needed
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint

    path = Path(checkpoint) if checkpoint is not None else shipped_checkpoint(entry.id)
    return entry.model_cls().from_checkpoint(path)


def load_predictor(name: str, checkpoint: str | Path | None = None) -> PredictionModel:
    """:func:`load_model` for a model that writes predictions files (kind program or
    dense); another kind is an :class:`InvalidArgument` saying which verb runs it."""
    from nsrmp_bench.reference_model.base import PredictionModel

    entry = get_model(name)
    if not entry.kind.writes_predictions:
        use = ("`nsrmp-bench detect --detector learned --data DATA --out D.jsonl`"
               if entry.kind is Kind.DETECTOR else
               "`nsrmp-bench reconstruct P.jsonl --data DATA --out DIR`")
        msg = (f"{entry.id} is a {entry.kind.value} model: it writes no predictions file; "
               f"run it with {use}")
        raise InvalidArgument(msg)
    model = load_model(name, checkpoint)
    assert isinstance(model, PredictionModel)
    return model
