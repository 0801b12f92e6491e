"""NSRM: the modules wired into scene -> split -> parse -> execute, batched.

:meth:`NSRM.forward_pieces` executes, for R rows, up to P sub-instructions in order on the
initial world; everything a model reads comes from :class:`~reference_model.encoded.Encoded`
inputs (tokens, crops, geometry, the object mask).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.encoded import Encoded
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig
from nsrmp_bench.reference_model.nsrm.executor import StepParse, execute_step
from nsrmp_bench.reference_model.nsrm.modules import (
    ActionSimulator,
    ConceptGrounder,
    RelationScorer,
    Splitter,
    Tagger,
    VisualExtractor,
)
from nsrmp_bench.reference_model.tokens import PAD

__all__ = [
    "NSRM",
    "Execution",
    "SceneTensors",
    "hard_pointers",
    "object_features",
    "piece_parses",
    "split_pieces",
]


@dataclass
class SceneTensors:
    """Per-row scene: attribute and relation log-probabilities, world (R, N, 5), mask."""

    attr_logp: Tensor
    rel_logp: Tensor
    world: Tensor
    mask: Tensor

    def repeat(self, index: Tensor) -> SceneTensors:
        """Rows ``index`` of this scene (candidates of the same episode share its scene)."""
        return SceneTensors(self.attr_logp[index], self.rel_logp[index], self.world[index],
                            self.mask[index])


@dataclass
class Execution:
    """The result of running R programs: the final world and per-step choices (R, P, ...)."""

    world: Tensor
    subjects: Tensor  # (R, P, N)
    bases: Tensor  # (R, P, N)
    actions: Tensor  # (R, P, 3)
    step_worlds: Tensor  # (R, P, N, 5)


class NSRM(nn.Module):
    """The neuro-symbolic reference model."""

    def __init__(self, vocab_size: int, cfg: NSRMConfig) -> None:
        super().__init__()
        self.cfg = cfg
        self.visual = VisualExtractor(cfg)
        self.concepts = ConceptGrounder(self.visual.out_dim, cfg)
        self.relations = RelationScorer(cfg)
        self.simulator = ActionSimulator(cfg)
        self.tagger = Tagger(vocab_size, cfg)
        self.splitter = Splitter(vocab_size, cfg)

    # --- scene -----------------------------------------------------------------------
    def features(self, enc: Encoded) -> Tensor:
        """Visual features (B, N, F) of the real objects (zeros for padding)."""
        return object_features(self.visual, enc)

    def scene(self, enc: Encoded, feats: Tensor | None = None) -> SceneTensors:
        """Ground the concepts on the episodes' objects (``feats``: cached features)."""
        feats = self.features(enc) if feats is None else feats
        attr = F.logsigmoid(self.concepts(feats))
        rel = F.logsigmoid(self.relations(enc.geometry))
        return SceneTensors(attr, rel, enc.geometry, enc.object_mask)

    # --- language ----------------------------------------------------------------------
    def tag(self, tokens: Tensor) -> tuple[Tensor, StepParse]:
        """Pointer logits (R, SLOTS, 1 + T) and the relaxed parse (pointer probabilities)."""
        ptr, attr, rel, act = self.tagger(tokens)
        parse = StepParse(torch.softmax(ptr, -1), torch.softmax(attr, -1),
                          torch.softmax(rel, -1), torch.softmax(act, -1))
        return ptr, parse

    # --- execution ---------------------------------------------------------------------
    def execute(self, scene: SceneTensors, parses: list[StepParse], piece_mask: Tensor,
                hard: bool) -> Execution:
        """Run step parses ``parses[p]`` (rows aligned with ``scene``) in order.

        ``piece_mask`` (R, P) says which rows have a p-th step; a row without one keeps its
        world. The previous step's subject is what ``it`` refers to.
        """
        world = scene.world
        prev: Tensor | None = None
        subjects, bases, actions, worlds = [], [], [], []
        for p, parse in enumerate(parses):
            new, subj, base, act = execute_step(parse, scene.attr_logp, scene.rel_logp, world,
                                                scene.mask, prev, self.simulator, hard)
            on = piece_mask[:, p, None]
            world = torch.where(on[..., None], new, world)
            prev = subj if prev is None else torch.where(on, subj, prev)
            subjects.append(subj)
            bases.append(base)
            actions.append(act)
            worlds.append(world)
        return Execution(world, torch.stack(subjects, 1), torch.stack(bases, 1),
                         torch.stack(actions, 1), torch.stack(worlds, 1))


def object_features(visual: nn.Module, enc: Encoded) -> Tensor:
    """The visual extractor's features (B, N, F) of the episodes' real objects (zeros for
    padding)."""
    b, n = enc.object_mask.shape
    real = enc.object_mask.reshape(-1)
    out: Tensor = visual(enc.crops.reshape(b * n, *enc.crops.shape[2:])[real])
    feats = out.new_zeros((b * n, out.shape[-1]))
    feats[real] = out
    return feats.reshape(b, n, -1)


def split_pieces(tokens: Tensor, cuts: list[list[int]]) -> tuple[Tensor, Tensor]:
    """Pieces of each row's tokens at its cut positions: (R, P, Tp) tokens, (R, P) mask.

    ``cuts[r]`` are the positions t where a new piece starts (sorted, each >= 1).
    """
    rows: list[list[Tensor]] = []
    for r, c in enumerate(cuts):
        seq = tokens[r][tokens[r] != PAD]
        bounds = [0, *c, len(seq)]
        rows.append([seq[a:b] for a, b in itertools.pairwise(bounds)])
    p = max(len(x) for x in rows)
    t = max(1, max(len(piece) for x in rows for piece in x))
    out = torch.full((len(rows), p, t), PAD, dtype=torch.long)
    mask = torch.zeros((len(rows), p), dtype=torch.bool)
    for r, pieces in enumerate(rows):
        for k, piece in enumerate(pieces):
            out[r, k, : len(piece)] = piece
            mask[r, k] = len(piece) > 0
    return out, mask


def hard_pointers(pointer_logits: Tensor) -> Tensor:
    """One-hot argmax pointers (R, SLOTS, 1 + T)."""
    return F.one_hot(pointer_logits.argmax(-1), pointer_logits.shape[-1]).float()


def piece_parses(parse: StepParse, pointers: Tensor, r: int, p: int) -> list[StepParse]:
    """Split parses of R * P pieces (row-major) into P parses of R rows, with ``pointers``
    (R * P, SLOTS, 1 + T) in place of the parse's own."""
    def part(x: Tensor, k: int) -> Tensor:
        return x.reshape(r, p, *x.shape[1:])[:, k]

    return [StepParse(part(pointers, k), part(parse.attribute, k), part(parse.relation, k),
                      part(parse.action, k)) for k in range(p)]
