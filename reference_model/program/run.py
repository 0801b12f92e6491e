"""The program models' class on the learned-model contract (NSRM v2, NMN+ v2): a
subclass names its id, config and step model; training and prediction are here, once.

Training reads ``data/train`` (selection on ``data/val``; a split without val selects on
the last tenth of train), fits the action rule, derives each episode's consistent
programs from its boxes, then runs two stages through the shared loop
(:func:`~nsrmp_bench.reference_model.training.train_stages`): ``single`` (one-step
programs where one box changed) and ``joint`` (splitter and step model on every episode).
Selection is on the in-loop val IoU-M of the model as it predicts (splitter included),
in the joint stage.
"""

from __future__ import annotations

import dataclasses
import json
import time
from abc import abstractmethod
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import torch

from nsrmp_bench.dataset import shared_camera
from nsrmp_bench.instruction_check import check_instruction
from nsrmp_bench.reference_model.base import (
    BEST,
    CARD,
    CONFIG,
    ProgramPredictionModel,
    TrainingPlan,
)
from nsrmp_bench.reference_model.checkpoints import save_checkpoint
from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.encoded import encode_targets
from nsrmp_bench.reference_model.program.data import (
    ProgramData,
    fit_part_rule,
    program_data,
    read_items,
    with_training_signal,
)
from nsrmp_bench.reference_model.program.ensemble import (
    EnsembleSplitter,
    EnsembleStep,
    member_seeds,
    train_members,
)
from nsrmp_bench.reference_model.program.inference import (
    Decoded,
    Oracle,
    decode,
    decoded_iou_m,
    decoded_predictions,
)
from nsrmp_bench.reference_model.program.modules import ProgramModel, Splitter, StepModel
from nsrmp_bench.reference_model.program.scene3d import ActionRule
from nsrmp_bench.reference_model.program.training import (
    fit_calibration,
    joint_loss,
    single_loss,
)
from nsrmp_bench.reference_model.tokens import Vocabulary
from nsrmp_bench.reference_model.training import LOG, Stage
from nsrmp_bench.results.model_cards import TrainingCard, write_training_card
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.storage.records import atomic_write_text

__all__ = ["INPUTS", "SUPERVISION", "ProgramModelBase"]

SUPERVISION = (
    "initial and final boxes only: the programs consistent with them under the action "
    "rule (no gold program, no lexed form, no template id, no reference labels, no step "
    "counts or categories)")
INPUTS = "instruction text, initial RGB, initial depth, initial (gold) boxes, the camera"
CALIBRATION_EPISODES = 512  # training episodes the splitter's calibration is fitted on


class ProgramModelBase(ProgramPredictionModel):
    """A program model on the shared parts: only its step model differs."""

    supervision = SUPERVISION
    inputs = INPUTS
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs_warmup": 3, "epochs_single": 1, "epochs_joint": 1, "batch_size": 8,
        "threads": 1, "members": 1}
    model: ProgramModel

    @classmethod
    @abstractmethod
    def step_model(cls, config: Any, vocab_size: int) -> StepModel:
        """The untrained step model for ``config``."""

    @classmethod
    def build_network(cls, config: Any, vocab_size: int,
                      state: Mapping[str, torch.Tensor]) -> ProgramModel:
        members = int(config.members)
        gap = int(config.splitter_gap)
        if members == 1:
            return ProgramModel(cls.step_model(config, vocab_size),
                                Splitter(vocab_size, gap=gap))
        return ProgramModel(
            EnsembleStep([cls.step_model(config, vocab_size) for _ in range(members)]),
            EnsembleSplitter([Splitter(vocab_size, gap=gap) for _ in range(members)]))

    @classmethod
    def _train(cls, data: Path, out: Path, cfg: ModelConfig, seed: int, threads: int,
               quiet: bool) -> Path:
        """One run, or with ``members`` > 1 that many runs in parallel (``out/member-K``,
        seeds :func:`~.ensemble.member_seeds`) put together into one checkpoint and
        validated as it predicts; its log holds every member's epochs (``member``) and the
        ensemble's line."""
        members = int(getattr(cfg, "members", 1))
        if members == 1:
            return super()._train(data, out, cfg, seed, threads, quiet)
        t0 = time.perf_counter()
        fresh = not (out / CONFIG).exists()  # a new run, or --restart deleted it
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / CONFIG, json.dumps(cfg.to_dict(), indent=1) + "\n")
        single = dataclasses.replace(cfg, members=1)  # type: ignore[type-var]
        seeds = member_seeds(seed, members)
        if not quiet:
            print(f"{cls.model_id}: training {members} members in parallel (seeds "
                  f"{', '.join(map(str, seeds))}) into {out}/member-0..{members - 1}")
        bests = train_members(cls.model_id, data, out, single.to_dict(), seed, members,
                              restart=fresh)
        loaded = [cls.from_checkpoint(b) for b in bests]
        network = ProgramModel(EnsembleStep([m.model.step for m in loaded]),
                               EnsembleSplitter([m.model.splitter for m in loaded]))
        network.rule = loaded[0].model.rule
        vocab = loaded[0].vocab
        network.eval()
        val_items, val_cats, selected_on = selection_items(data)
        val = with_training_signal(program_data(val_items, vocab, network.rule), val_items,
                                   val_cats, network.rule)
        score, figures = validation_scores(network, val, gold_steps(val_items))
        cards = [json.loads((b.parent / CARD).read_text("utf-8")) for b in bests]
        lines = [{**json.loads(line), "member": k}
                 for k, b in enumerate(bests)
                 for line in (b.parent / LOG).read_text("utf-8").splitlines()]
        lines.append({"stage": "ensemble", "members": members, "val_iou_m": round(score, 5),
                      "best": True, "seconds": round(time.perf_counter() - t0, 1),
                      **{k: round(v, 5) for k, v in figures.items()}})
        atomic_write_text(out / LOG, "".join(json.dumps(x) + "\n" for x in lines))
        best = out / BEST
        save_checkpoint(best, cls.model_id, cfg.to_dict(), vocab.to_list(),
                        network.state_dict(), {"seed": seed, "data": str(data),
                                               "member_seeds": seeds})
        train_seconds = sum(float(c["train_seconds"]) for c in cards)
        card = TrainingCard(
            model=cls.model_id, label=cls.label,
            training_data=(f"{cards[0]['training_data']}; {members} members (seeds "
                           f"{', '.join(map(str, seeds))}) trained in parallel, each "
                           f"selected on {selected_on}, read as one"),
            train_seconds=round(train_seconds, 1),
            wall_seconds=round(time.perf_counter() - t0, 1),
            read_seconds=round(sum(float(c.get("read_seconds") or 0.0) for c in cards), 1),
            parameters=sum(p.numel() for p in network.parameters()),
            score_name="val IoU-M", best_score=round(score, 4), seed=seed, threads=threads,
            supervision=cls.supervision, inputs=cls.inputs, config=cfg.to_dict())
        write_training_card(out / CARD, card)
        return best

    @classmethod
    def plan_training(cls, data: Path, config: Any, seed: int) -> TrainingPlan:
        t0 = time.perf_counter()
        items, ds = read_items(data / "train")
        vocab = Vocabulary.build(check_instruction(it["inputs"].get("instruction"),
                                                   f"the instruction of episode {it['id']!r}")
                                 for it in items)
        cats = ds.collection.index.set_index("id").to_dict("index")
        val_items, val_cats, selected_on = selection_items(data, (items, cats))
        if selected_on != "val":
            items = items[: len(items) - len(val_items)]
        # the states depend on the rule's fixed centre only, so one encoding serves the fit
        train = program_data(items, vocab, ActionRule())
        encode_targets(train.enc, items, cats)
        rule = fit_part_rule(train)
        train = with_training_signal(train, items, cats, rule)
        val = with_training_signal(program_data(val_items, vocab, rule), val_items,
                                   val_cats, rule)
        read = time.perf_counter() - t0
        torch.manual_seed(seed)
        model = cls.build_network(config, len(vocab), {})
        model.rule = rule
        assert train.consistent is not None and train.moved is not None
        single_rows = torch.tensor([i for i, c in enumerate(train.consistent)
                                    if train.moved[i] == 1 and len(c.one)], dtype=torch.long)
        joint_rows = torch.tensor([i for i, c in enumerate(train.consistent)
                                   if len(c.one) or len(c.two)], dtype=torch.long)

        def single(rows: torch.Tensor) -> torch.Tensor:
            return single_loss(model.step, train, rows.tolist())

        def joint(rows: torch.Tensor) -> torch.Tensor:
            return joint_loss(model.step, model.splitter, train, rows.tolist(),
                              joins=int(config.splitter_joins))

        stages = [
            Stage("warmup", int(config.epochs_warmup), single_rows,
                  model.step.warmup_parameters, single, float(config.lr),
                  int(config.batch_size)),
            Stage("single", int(config.epochs_single), single_rows,
                  lambda: list(model.step.parameters()), single, float(config.lr),
                  int(config.batch_size)),
            Stage("joint", int(config.epochs_joint), joint_rows,
                  lambda: list(model.parameters()), joint,
                  float(config.lr) * float(config.joint_lr_scale),
                  int(config.batch_size), uses_splitter=True,
                  decay=bool(config.joint_decay)),
        ]
        gold = gold_steps(val_items)  # for the log's figures only

        calibration_rows = joint_rows[:CALIBRATION_EPISODES].tolist()

        def validate(stage: Stage) -> tuple[float, dict[str, float]]:
            if stage.uses_splitter:
                fit_calibration(model.step, model.splitter, train, calibration_rows)
            return validation_scores(model, val, gold)

        return TrainingPlan(
            network=model, stages=stages, validate=validate, vocab=vocab.to_list(),
            training_data=(f"{len(train)} training episodes ({len(single_rows)} with one "
                           f"changed box in the warmup and single stages); selection on "
                           f"{selected_on}"),
            read_seconds=read)

    @property
    def rule(self) -> ActionRule:
        """The action rule this checkpoint was trained with."""
        return self.model.rule

    def predict(self, items: Sequence[dict[str, Any]],
                oracle: Oracle | None = None) -> Iterator[Prediction]:
        """Predictions for ``items`` (``oracle``: the diagnosis's gold substitutions)."""
        camera = shared_camera(items)
        data, decoded = self._decode(items, oracle)
        ids = [str(it["id"]) for it in items]
        return decoded_predictions(ids, data, decoded, camera)

    def programs(self, items: Sequence[dict[str, Any]],
                 oracle: Oracle | None = None) -> list[list[tuple[int, int, int]]]:
        """Per item, its decoded steps (``oracle``: the diagnosis's gold substitutions)."""
        return self._decode(items, oracle)[1].steps

    def perceived_sizes(self, sizes: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """The object sizes (B, N, 2) the perception reads at prediction: the estimated
        ones (a model with a size calibration rescales them)."""
        del mask
        return sizes

    def _decode(self, items: Sequence[dict[str, Any]],
                oracle: Oracle | None = None) -> tuple[ProgramData, Decoded]:
        self.set_threads()
        data = program_data(list(items), self.vocab, self.model.rule)
        return data, decode(self.model.step, self.model.splitter, data, self.model.rule,
                            oracle, perceived=self.perceived_sizes)


def selection_items(
    data: Path, train: tuple[list[dict[str, Any]], dict[str, Any]] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, Any], str]:
    """The episodes a run selects on, their categories, and what they are called: ``val``,
    or where the split has none the last tenth of ``train`` (read here unless given as
    items and categories)."""
    val_dir = data / "val"
    if (val_dir / "manifest.json").exists():
        val_items, vds = read_items(val_dir)
        return val_items, vds.collection.index.set_index("id").to_dict("index"), "val"
    if train is None:
        items, ds = read_items(data / "train")
        train = items, ds.collection.index.set_index("id").to_dict("index")
    items, cats = train
    return items[len(items) - max(1, len(items) // 10):], cats, "the last tenth of train"


def gold_steps(items: Sequence[dict[str, Any]]) -> list[list[tuple[int, ...]]]:
    """Each item's gold steps (action, subject, base), read from its targets: for the log's
    validation figures only."""
    return [[tuple(int(x) for x in row) for row in it["targets"]["grounded"].tolist()]
            for it in items]


def validation_scores(model: ProgramModel, val: ProgramData,
                      gold: list[list[tuple[int, ...]]]) -> tuple[float, dict[str, float]]:
    """The model's in-loop val IoU-M as it predicts (splitter included) and the log's
    figures (:func:`validation_figures`)."""
    decoded = decode(model.step, model.splitter, val, model.rule)
    return decoded_iou_m(val, decoded), validation_figures(val, decoded, gold)


def validation_figures(data: ProgramData, decoded: Decoded,
                       gold: list[list[tuple[int, ...]]]) -> dict[str, float]:
    """The log's validation figures: subject accuracy (all steps) on episodes with and
    without relational references, and split accuracy (the right number of steps)."""
    hit = {True: [0, 0], False: [0, 0]}
    split = 0
    relational = data.enc.meta["relational"].tolist()
    for steps, want, rel in zip(decoded.steps, gold, relational, strict=True):
        split += len(steps) == len(want)
        for k, (_, subject, _) in enumerate(want):
            hit[bool(rel)][1] += 1
            hit[bool(rel)][0] += k < len(steps) and steps[k][1] == subject
    return {"val_subject_relational": hit[True][0] / max(hit[True][1], 1),
            "val_subject_attribute": hit[False][0] / max(hit[False][1], 1),
            "val_split": split / max(len(gold), 1)}
