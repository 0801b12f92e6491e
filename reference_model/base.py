"""The learned-model contract, torch half: one base class every learned model subclasses.

A model is a subclass of :class:`LearnedModel` (or of one of its kinds,
:class:`PredictionModel` for the models that write predictions files) that names

- ``model_id`` (``name-vN``), ``kind`` (:class:`~.contract.Kind`) and ``config_cls`` (a
  :class:`~.contract.ModelConfig` dataclass);
- ``supervision`` and ``inputs``: what its model card states;
- :meth:`LearnedModel.build_network`: the untrained network for a config (loading calls it);
- :meth:`LearnedModel.plan_training`: reads the data and returns a :class:`TrainingPlan`
  (network, curriculum stages, validation score, what the card says of the data);
- its inference entry (:meth:`PredictionModel.predict` for program and dense models);
- ``tiny_overrides``: config changes for a run of seconds (the contract tests use them).

Everything else is done once, here: :meth:`LearnedModel.from_checkpoint` loads and checks a
checkpoint; :meth:`LearnedModel.train` is the run scaffold (data check, a resume with a
changed config refused before anything is written, torch threads, seed, atomic
``config.json``, ``best.pt``/``last.pt``, ``log.jsonl`` through the one training loop, and the
typed model card written by :func:`~nsrmp_bench.results.model_cards.write_training_card`).
"""

from __future__ import annotations

import json
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import torch
from torch import Tensor, nn

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.checkpoints import load_checkpoint, save_checkpoint
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.tokens import Vocabulary
from nsrmp_bench.reference_model.training import CHECKPOINT, LOG, Stage, train_stages
from nsrmp_bench.results.model_cards import TrainingCard, write_training_card
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.storage.records import atomic_write_text

__all__ = ["LearnedModel", "PredictionModel", "ProgramPredictionModel", "TrainingPlan",
           "run_files"]

M = TypeVar("M", bound="LearnedModel")

BEST = "best.pt"
CONFIG = "config.json"
CARD = "card.json"


def run_files(out: Path) -> list[Path]:
    """The files a training run writes into ``out`` (``--restart`` deletes them)."""
    return [out / n for n in (CONFIG, BEST, CHECKPOINT, LOG, CARD)]


@dataclass
class TrainingPlan:
    """What a model's :meth:`LearnedModel.plan_training` returns: the network to train, its
    curriculum, how to score it on validation data, and what the card says of the data."""

    network: nn.Module
    stages: Sequence[Stage]
    # higher is better; selects best.pt (and, with a dict, more figures for the log)
    validate: Callable[[Stage], float | tuple[float, dict[str, float]]]
    training_data: str  # the card's sentence (how many episodes, from where, selected on)
    vocab: list[str] = field(default_factory=list)
    score_name: str = "val IoU-M"
    read_seconds: float | None = None  # time spent reading the data, if stated apart
    checkpoint_extra: Callable[[], dict[str, Any]] | None = None  # added to best.pt's extra


class LearnedModel(ABC):
    """A loaded learned model: its config, network, vocabulary and checkpoint path."""

    model_id: ClassVar[str]
    kind: ClassVar[Kind]
    config_cls: ClassVar[type[ModelConfig]]
    label: ClassVar[str] = ""  # said beside the id wherever its results are shown
    supervision: ClassVar[str]  # the model card's "supervision"
    inputs: ClassVar[str]  # the model card's "inputs it reads"
    data_hint: ClassVar[str] = "e.g. data/paper-v2"  # said when --data has no train part
    tiny_overrides: ClassVar[dict[str, object]] = {}
    """Config changes for a run of seconds on a 16-episode split (smoke-v2/test as train
    and val): the contract tests train every registered model with them."""

    def __init__(self, config: ModelConfig, model: nn.Module, vocab: Vocabulary,
                 checkpoint: Path) -> None:
        self.config = config
        self.model = model
        self.vocab = vocab
        self.checkpoint = checkpoint

    # loading -----------------------------------------------------------------------------
    @classmethod
    @abstractmethod
    def build_network(cls, config: Any, vocab_size: int,
                      state: Mapping[str, Tensor]) -> nn.Module:
        """The network for ``config`` (``state``: the weights about to be loaded, for a
        size that only they record)."""

    @classmethod
    def from_checkpoint(cls: type[M], checkpoint: str | Path) -> M:
        """Load a checkpoint of this model (checked to be one), in eval mode."""
        payload = load_checkpoint(checkpoint, cls.model_id)
        config = cls.config_cls.from_dict(payload["config"])
        vocab = Vocabulary(tuple(payload["vocab"]))
        network = cls.build_network(config, len(vocab), payload["state"])
        network.load_state_dict(payload["state"])
        network.eval()
        return cls(config, network, vocab, Path(checkpoint))

    def set_threads(self) -> None:
        """Set torch's threads to the config's (before any inference)."""
        torch.set_num_threads(self.config.threads)  # type: ignore[attr-defined]

    # training ----------------------------------------------------------------------------
    @classmethod
    def check_data(cls, data: Path, config: Any) -> None:
        """Refuse ``data`` unless it holds what training reads (default: a finished
        ``train`` part)."""
        del config
        if not (data / "train" / "manifest.json").exists():
            msg = (f"{data} has no finished part 'train' ({data / 'train'}); pass a split "
                   f"root holding train/ (and val/), {cls.data_hint}")
            raise InvalidArgument(msg)

    @classmethod
    @abstractmethod
    def plan_training(cls, data: Path, config: Any, seed: int) -> TrainingPlan:
        """Read the data and build the network and curriculum (torch is seeded already)."""

    @classmethod
    def train(cls, data: Path, out: Path, *, seed: int = 0, config: ModelConfig | None = None,
              quiet: bool = False, restart: bool = False) -> Path:
        """Train on ``data``, writing the run into ``out``; returns ``out/best.pt``.

        Rerunning into ``out`` resumes from ``last.pt``; a different config there is refused
        before anything is written (``restart=True`` deletes the run's files first)."""
        cfg = config if config is not None else cls.config_cls()
        if not isinstance(cfg, cls.config_cls):
            msg = (f"{cls.model_id} trains with a {cls.config_cls.__qualname__}, not a "
                   f"{type(cfg).__qualname__}")
            raise InvalidArgument(msg)
        cls.check_data(data, cfg)
        _prepare_out(out, cfg, restart)
        threads: int = cfg.threads  # type: ignore[attr-defined]
        torch.set_num_threads(threads)
        with _deterministic():
            return cls._train(data, out, cfg, seed, threads, quiet)

    @classmethod
    def _train(cls, data: Path, out: Path, cfg: ModelConfig, seed: int, threads: int,
               quiet: bool) -> Path:
        """:meth:`train` once the data, the output folder and the threads are settled."""
        torch.manual_seed(seed)
        t0 = time.perf_counter()
        plan = cls.plan_training(data, cfg, seed)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / CONFIG, json.dumps(cfg.to_dict(), indent=1) + "\n")
        best = out / BEST
        network = plan.network

        def on_best() -> None:
            extra: dict[str, Any] = {"seed": seed, "data": str(data)}
            if plan.checkpoint_extra is not None:
                extra.update(plan.checkpoint_extra())
            save_checkpoint(best, cls.model_id, cfg.to_dict(), plan.vocab,
                            network.state_dict(), extra)

        state = train_stages(network, plan.stages, out, seed=seed, validate=plan.validate,
                             on_best=on_best, quiet=quiet, score_name=plan.score_name)
        card = TrainingCard(
            model=cls.model_id, label=cls.label, training_data=plan.training_data,
            train_seconds=round(state.seconds, 1),
            wall_seconds=round(time.perf_counter() - t0, 1),
            read_seconds=None if plan.read_seconds is None else round(plan.read_seconds, 1),
            parameters=sum(p.numel() for p in network.parameters()),
            score_name=plan.score_name, best_score=round(state.best, 4), seed=seed,
            threads=threads, supervision=cls.supervision, inputs=cls.inputs,
            config=cfg.to_dict())
        write_training_card(out / CARD, card)
        return best


@contextmanager
def _deterministic() -> Iterator[None]:
    """Same seed, same bytes with several threads too: while training, ops whose parallel
    accumulation order varies (the backward of indexing with repeated indices) take their
    deterministic implementations; the process's setting is restored afterwards."""
    before = torch.are_deterministic_algorithms_enabled()
    warn = torch.is_deterministic_algorithms_warn_only_enabled()
    torch.use_deterministic_algorithms(True, warn_only=True)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(before, warn_only=warn)


def _prepare_out(out: Path, cfg: ModelConfig, restart: bool) -> None:
    """Delete the run's files (``restart``) or refuse a resume with another config."""
    if restart:
        for path in run_files(out):
            path.unlink(missing_ok=True)
        return
    config = out / CONFIG
    if not config.exists():
        return
    try:
        old = json.loads(config.read_text("utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        msg = (f"{config} cannot be read ({exc}); pass --out to a new folder, or --restart "
               "to start this run over")
        raise InvalidArgument(msg) from exc
    differ = cfg.differences(old)
    if differ:
        mine = cfg.to_dict()
        said = ", ".join(f"{k} ({old.get(k, 'absent')!r} there, {mine.get(k, 'absent')!r} "
                         "now)" for k in differ)
        msg = (f"{out} holds a run with another config: {said}; resuming it would mix the "
               "two. Pass --out to a new folder, or --restart to start this run over "
               "(deletes its checkpoints, log and card)")
        raise InvalidArgument(msg)


class PredictionModel(LearnedModel):
    """A model that writes the public predictions format (kinds program and dense)."""

    @abstractmethod
    def predict(self, items: Sequence[dict[str, Any]]) -> Iterator[Prediction]:
        """Predictions for dataset items (``{"id", "inputs"}``; never ``targets``); the
        camera that back-projects positions is the items' own
        (:func:`~nsrmp_bench.dataset.shared_camera`)."""


class ProgramPredictionModel(PredictionModel):
    """A model of kind program: it also says the grounded program it predicts, which the
    closed loop (:mod:`nsrmp_bench.envs.policies`) issues one step per move."""

    kind: ClassVar[Kind] = Kind.PROGRAM

    @abstractmethod
    def programs(self, items: Sequence[dict[str, Any]]) -> list[list[tuple[int, int, int]]]:
        """Per item, its predicted steps ``[(action index, subject, base), ...]``."""
