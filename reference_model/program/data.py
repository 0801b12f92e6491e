"""A split part prepared for the program models: the encoded inputs, each episode's 3D
state and, for training, its consistent programs (:mod:`.consistent`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nsrmp_bench.dataset import EpisodeDataset, item_camera
from nsrmp_bench.reference_model.encoded import Encoded, encode_inputs, encode_targets
from nsrmp_bench.reference_model.program.consistent import (
    Consistent,
    changed_boxes,
    consistent_programs,
    fit_rule,
)
from nsrmp_bench.reference_model.program.scene3d import ActionRule, SceneState, scene_state
from nsrmp_bench.reference_model.tokens import PAD, Vocabulary

__all__ = ["ProgramData", "fit_part_rule", "program_data", "read_items"]


@dataclass
class ProgramData:
    """Encoded episodes, their token lists, 3D states and (training) consistent programs."""

    enc: Encoded
    tokens: list[list[int]]
    states: list[SceneState]
    consistent: list[Consistent] | None = None
    moved: list[int] | None = None  # how many boxes changed (training)

    def __len__(self) -> int:
        return len(self.enc)


def read_items(path: Path) -> tuple[list[dict[str, Any]], Any]:
    """Every item of the part at ``path`` through ``EpisodeDataset``, and the dataset."""
    ds = EpisodeDataset(path)
    return list(ds.iter_items()), ds


def program_data(items: list[dict[str, Any]], vocab: Vocabulary,
                 rule: ActionRule) -> ProgramData:
    """Inputs only: what prediction reads (each episode's 3D state through its own camera)."""
    enc = encode_inputs(items, vocab)
    tokens = [[int(t) for t in row if t != PAD] or [PAD] for row in enc.tokens.tolist()]
    states = [
        scene_state(enc.boxes[i, m].numpy(), enc.geometry[i, m, 4].numpy(),
                    item_camera(items[i]), rule)
        for i, m in enumerate(enc.object_mask)
    ]
    return ProgramData(enc, tokens, states)


def with_training_signal(data: ProgramData, items: list[dict[str, Any]],
                         categories: dict[str, Any], rule: ActionRule) -> ProgramData:
    """Add final boxes and every episode's consistent programs (reads ``targets``' final
    boxes only)."""
    encode_targets(data.enc, items, categories)
    assert data.enc.final_boxes is not None
    cons, moved = [], []
    for i, state in enumerate(data.states):
        n = len(state)
        final = data.enc.final_boxes[i, :n].numpy().astype(np.float64)
        cons.append(consistent_programs(state, final, rule))
        moved.append(int(changed_boxes(data.enc.boxes[i, :n].numpy(), final).sum()))
    data.consistent = cons
    data.moved = moved
    return data


def fit_part_rule(data: ProgramData, limit: int = 1000) -> ActionRule:
    """The action rule fitted on up to ``limit`` episodes where exactly one box changed."""
    assert data.enc.final_boxes is not None
    states, finals = [], []
    for i, state in enumerate(data.states):
        n = len(state)
        final = data.enc.final_boxes[i, :n].numpy().astype(np.float64)
        if int(changed_boxes(data.enc.boxes[i, :n].numpy(), final).sum()) == 1:
            states.append(state)
            finals.append(final)
        if len(states) >= limit:
            break
    return fit_rule(states, finals)
