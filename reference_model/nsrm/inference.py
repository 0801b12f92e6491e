"""NSRM at inference: recursive splitting, argmax pointers, hard ``unique``.

Returns per episode the grounded program (action, subject, base per step) and the world
after each step, from which the predictions writer makes boxes.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import torch
from torch import Tensor

from nsrmp_bench.dataset import shared_camera
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.reference_model.base import ProgramPredictionModel
from nsrmp_bench.reference_model.encoded import Encoded, encode_inputs
from nsrmp_bench.reference_model.nsrm.loss import iou, world_to_boxes
from nsrmp_bench.reference_model.nsrm.model import NSRM, hard_pointers, piece_parses, split_pieces
from nsrmp_bench.reference_model.nsrm.modules import Splitter
from nsrmp_bench.reference_model.predictions import model_predictions
from nsrmp_bench.reference_model.tokens import PAD
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["Inferred", "ProgramPredictor", "infer", "inferred_iou_m", "inferred_predictions",
           "split_recursively"]


class HasSplitter(Protocol):
    """A model with NSRM's splitter (NSRM, NMN+)."""

    @property
    def splitter(self) -> Splitter: ...


@dataclass
class Inferred:
    """Per episode: steps ``[(action index, subject, base), ...]`` and worlds (S, N, 5)."""

    steps: list[list[tuple[int, int, int]]]
    worlds: list[Tensor]


def split_recursively(model: HasSplitter, tokens: Tensor, max_steps: int) -> list[list[int]]:
    """Cut positions per row: split each piece at the splitter's argmax until it says "no
    split" (or there are ``max_steps`` pieces)."""
    seqs = [row[row != PAD] for row in tokens]
    pieces: list[list[tuple[int, int]]] = [[(0, len(s))] for s in seqs]
    done: list[list[bool]] = [[False] for _ in seqs]
    while True:
        todo = [(r, k) for r in range(len(seqs)) for k in range(len(pieces[r]))
                if not done[r][k]]
        if not todo:
            break
        t = max(pieces[r][k][1] - pieces[r][k][0] for r, k in todo)
        batch = torch.full((len(todo), max(t, 1)), PAD, dtype=torch.long)
        for i, (r, k) in enumerate(todo):
            a, b = pieces[r][k]
            batch[i, : b - a] = seqs[r][a:b]
        choice = model.splitter(batch).argmax(-1).tolist()
        for (r, k), c in sorted(zip(todo, choice, strict=True), reverse=True):
            if c == 0 or len(pieces[r]) >= max_steps:
                done[r][k] = True
                continue
            a, b = pieces[r][k]
            cut = a + c - 1
            pieces[r][k: k + 1] = [(a, cut), (cut, b)]
            done[r][k: k + 1] = [False, False]
    return [[a for a, _ in p[1:]] for p in pieces]


@torch.no_grad()
def infer(model: NSRM, enc: Encoded, batch_size: int = 128, split: bool = True) -> Inferred:
    """Programs and per-step worlds of every episode of ``enc`` (model in eval mode).

    ``split=False`` reads every instruction as one step (validation before the splitter
    has been trained)."""
    model.eval()
    steps: list[list[tuple[int, int, int]]] = []
    worlds: list[Tensor] = []
    for lo in range(0, len(enc), batch_size):
        b = enc.select(range(lo, min(lo + batch_size, len(enc))))
        cuts = (split_recursively(model, b.tokens, model.cfg.max_steps) if split
                else [[] for _ in range(len(b))])
        pieces, pmask = split_pieces(b.tokens, cuts)
        r, p, t = pieces.shape
        ptr, parse = model.tag(pieces.reshape(r * p, t))
        parses = piece_parses(parse, hard_pointers(ptr), r, p)
        ex = model.execute(model.scene(b), parses, pmask, hard=True)
        n_obj = b.object_mask.sum(1).tolist()
        for i in range(r):
            n_steps = int(pmask[i].sum())
            steps.append([(int(ex.actions[i, k].argmax()), int(ex.subjects[i, k].argmax()),
                           int(ex.bases[i, k].argmax())) for k in range(n_steps)])
            worlds.append(ex.step_worlds[i, :n_steps, : n_obj[i]].clone())
    return Inferred(steps, worlds)


def inferred_iou_m(enc: Encoded, res: Inferred) -> float:
    """Mean IoU over the objects whose final box moved (IoU <= 0.9), for model selection.

    The figures we report come from the public scorer on a predictions file; this is the
    cheap in-loop number the progress bar shows and the best checkpoint is chosen by.
    """
    assert enc.final_boxes is not None
    scores = []
    for i in range(len(enc)):
        n = int(enc.object_mask[i].sum())
        gold, init = enc.final_boxes[i, :n], enc.boxes[i, :n]
        pred = world_to_boxes(res.worlds[i][-1], enc.image_size) if res.steps[i] else init
        moved = iou(init, gold) <= 0.9
        if moved.any():
            scores.append(float(iou(pred, gold)[moved].mean()))
    return sum(scores) / max(1, len(scores))


def inferred_predictions(enc: Encoded, res: Inferred, camera: Camera) -> Iterator[Prediction]:
    """The public predictions of an object-centric model's inferred steps and worlds
    (positions by back-projecting the box centres through ``camera``)."""
    boxes = [world_to_boxes(w, enc.image_size).double().numpy() for w in res.worlds]
    depths = [w[..., 4].double().numpy() for w in res.worlds]
    n = enc.object_mask.sum(1).tolist()
    init = [enc.boxes[i, : n[i]].double().numpy() for i in range(len(enc))]
    return model_predictions(enc.ids, init, res.steps, boxes, depths, camera)


class ProgramPredictor(ProgramPredictionModel):
    """A loaded program model (NSRM, NMN+): predicts from what ``EpisodeDataset`` gives as
    ``inputs`` only. A subclass names its id, config and network
    (:meth:`~nsrmp_bench.reference_model.base.LearnedModel.build_network`), its curriculum
    (``plan_training``) and its inference (:meth:`run`)."""

    @abstractmethod
    def run(self, enc: Encoded) -> Inferred:
        """The network over encoded inputs."""

    def infer(self, items: Sequence[dict[str, Any]]) -> tuple[Encoded, Inferred]:
        """Encode the items' inputs and run the model."""
        self.set_threads()
        enc = encode_inputs(items, self.vocab)
        return enc, self.run(enc)

    def predict(self, items: Sequence[dict[str, Any]]) -> Iterator[Prediction]:
        """Predictions for dataset items (``{"id", "inputs"}``), positions via their camera."""
        camera = shared_camera(items)
        enc, res = self.infer(items)
        return inferred_predictions(enc, res, camera)

    def programs(self, items: Sequence[dict[str, Any]]) -> list[list[tuple[int, int, int]]]:
        """Per item, its predicted steps (v1 reads 2D boxes only, not the camera)."""
        return self.infer(items)[1].steps
