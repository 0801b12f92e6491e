"""A split part encoded for the dense network: pooled RGB-D images and tokens (inputs),
and the pick and place cells (targets, for training only).

:func:`encode_items` reads only each item's ``inputs`` (instruction, initial RGB, depth
and boxes) unless asked for targets: then also the gold, the moved object (the first step's
subject) and its box centres before and after the step. Images are pooled as they are
read, so 10,000 episodes fit in memory.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from numpy.typing import ArrayLike
from torch import Tensor

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.instruction_check import check_instruction
from nsrmp_bench.reference_model.tokens import PAD, Vocabulary

__all__ = ["DenseInputs", "cell_centres", "cells_of", "encode_items", "encode_part"]


@dataclass
class DenseInputs:
    """E episodes: tokens, pooled images, initial boxes, and (training) target cells."""

    ids: list[str]
    tokens: Tensor  # (E, T) int64, PAD-padded
    rgb: Tensor  # (E, 3, h, w) uint8, pooled
    depth: Tensor  # (E, 1, h, w) float16, per-image standardised, pooled
    boxes: list[np.ndarray[Any, Any]]  # per episode (N, 4) initial pixel xyxy
    image_size: tuple[int, int]  # (width, height) of the original image
    scale: int
    pick: Tensor | None = None  # (E,) flat cell index of the pick target
    place: Tensor | None = None  # (E,) flat cell index of the place target
    subject: Tensor | None = None  # (E,) the moved object (validation)
    place_box: Tensor | None = None  # (E, 4) its box after the step (validation)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def grid(self) -> tuple[int, int]:
        """(h, w) of the heatmaps: half the pooled image's."""
        return int(self.rgb.shape[-2]) // 2, int(self.rgb.shape[-1]) // 2

    @property
    def cell(self) -> int:
        """The side of a heatmap cell in image pixels."""
        return 2 * self.scale

    def image(self, rows: Tensor) -> Tensor:
        """(B, 4, h, w) float32 network input of ``rows``: RGB in [0, 1] and depth."""
        rgb = self.rgb[rows].float() / 255.0
        return torch.cat([rgb, self.depth[rows].float()], dim=1)

    def tokens_of(self, rows: Tensor) -> Tensor:
        """(B, T') tokens of ``rows``, trimmed to the longest."""
        tok = self.tokens[rows]
        t = max(1, int((tok != PAD).sum(1).max()))
        return tok[:, :t]


def _np(x: Tensor | ArrayLike) -> np.ndarray[Any, Any]:
    return x.numpy() if isinstance(x, Tensor) else np.asarray(x)


def _input_row(item: Mapping[str, Any], scale: int) -> tuple[Tensor, Tensor, tuple[int, int]]:
    inp = item["inputs"]
    if inp.get("rgb") is None or inp.get("boxes") is None:
        msg = (f"episode {item['id']!r} has no rendering (RGB and boxes); the dense "
               "baseline reads the initial image: generate the split with rendering")
        raise InvalidArgument(msg)
    rgb = torch.as_tensor(_np(inp["rgb"])).permute(2, 0, 1).float()
    h, w = rgb.shape[-2:]
    if h % (2 * scale) or w % (2 * scale):
        msg = (f"episode {item['id']!r}: image {w}x{h} is not divisible by twice the scale "
               f"{scale}; pass --set scale=N with 2N dividing both")
        raise InvalidArgument(msg)
    depth = torch.as_tensor(_np(inp["depth"]), dtype=torch.float32)[None]
    depth = (depth - depth.mean()) / (depth.std() + 1e-6)
    pooled = F.avg_pool2d(rgb[None], scale)[0].round().clamp(0, 255).to(torch.uint8)
    return pooled, F.avg_pool2d(depth[None], scale)[0].to(torch.float16), (int(w), int(h))


def _target_row(item: Mapping[str, Any]) -> tuple[int, np.ndarray[Any, Any],
                                                  np.ndarray[Any, Any]]:
    tg = item["targets"]
    subject = int(_np(tg["grounded"])[0][1])
    states = _np(tg["boxes"])  # (S + 1, N, 4): the first step's subject before and after
    return subject, np.asarray(states[0][subject], np.float64), np.asarray(states[1][subject],
                                                                         np.float64)


def _centres(boxes: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    return np.stack([(boxes[:, 0] + boxes[:, 2]) / 2, (boxes[:, 1] + boxes[:, 3]) / 2], 1)


@dataclass
class _Record:
    """One episode, encoded (numpy, so that reader processes can return it)."""

    id: str
    rgb: np.ndarray[Any, Any]  # (3, h, w) uint8
    depth: np.ndarray[Any, Any]  # (1, h, w) float16
    size: tuple[int, int]
    boxes: np.ndarray[Any, Any]
    text: str
    target: tuple[int, np.ndarray[Any, Any], np.ndarray[Any, Any]] | None


def _record(item: Mapping[str, Any], scale: int, targets: bool) -> _Record:
    rgb, depth, size = _input_row(item, scale)
    return _Record(str(item["id"]), rgb.numpy(), depth.numpy(), size,
                   np.asarray(_np(item["inputs"]["boxes"]), dtype=np.float64),
                   check_instruction(item["inputs"].get("instruction"),
                                     f"the instruction of episode {item['id']!r}"),
                   _target_row(item) if targets else None)


def _assemble(records: list[_Record], vocab: Vocabulary | None, scale: int,
              targets: bool) -> tuple[DenseInputs, Vocabulary]:
    if not records:
        msg = "no episodes to encode; the data holds no (single-step) episodes"
        raise InvalidArgument(msg)
    if vocab is None:
        vocab = Vocabulary.build(r.text for r in records)
    toks = [vocab.encode(r.text) or [PAD] for r in records]
    tokens = torch.full((len(toks), max(len(t) for t in toks)), PAD, dtype=torch.long)
    for i, t in enumerate(toks):
        tokens[i, : len(t)] = torch.tensor(t)
    enc = DenseInputs([r.id for r in records], tokens,
                      torch.from_numpy(np.stack([r.rgb for r in records])),
                      torch.from_numpy(np.stack([r.depth for r in records])),
                      [r.boxes for r in records], records[0].size, scale)
    if targets:
        gold = [r.target for r in records if r.target is not None]
        enc.pick = cells_of(_centres(np.stack([g[1] for g in gold])), enc)
        enc.place = cells_of(_centres(np.stack([g[2] for g in gold])), enc)
        enc.subject = torch.tensor([g[0] for g in gold], dtype=torch.long)
        enc.place_box = torch.from_numpy(np.stack([g[2] for g in gold]))
    return enc, vocab


def encode_items(items: Iterable[Mapping[str, Any]], vocab: Vocabulary | None, scale: int,
                 *, targets: bool) -> tuple[DenseInputs, Vocabulary]:
    """Encode dataset items in one pass (images are pooled as they are read).

    Only ``inputs`` are read unless ``targets``: then also the pick and place cells, the
    first step's subject's box centres before and after the step (the gold). Without
    ``vocab`` the vocabulary is built from these items' instructions (training).
    """
    return _assemble([_record(item, scale, targets) for item in items], vocab, scale,
                     targets)


def _read_chunk(job: tuple[str, list[int], int, bool]) -> list[_Record]:
    from nsrmp_bench.dataset import EpisodeDataset

    path, rows, scale, targets = job
    ds = EpisodeDataset(path)
    return [_record(ds[i], scale, targets) for i in rows]


def cells_of(points: np.ndarray[Any, Any], enc: DenseInputs) -> Tensor:
    """Flat cell indices (E,) of pixel points (E, 2)."""
    h, w = enc.grid
    col = np.clip(np.floor(points[:, 0] / enc.cell), 0, w - 1).astype(np.int64)
    row = np.clip(np.floor(points[:, 1] / enc.cell), 0, h - 1).astype(np.int64)
    return torch.from_numpy(row * w + col)


def cell_centres(cells: Tensor, enc: DenseInputs) -> np.ndarray[Any, Any]:
    """Pixel points (E, 2) at the centres of flat cell indices."""
    w = enc.grid[1]
    c = cells.numpy()
    return np.stack([(c % w + 0.5) * enc.cell, (c // w + 0.5) * enc.cell], axis=1)


def encode_part(path: str | Path, vocab: Vocabulary | None, scale: int, *,
                single_step: bool, targets: bool, limit: int | None = None,
                workers: int = 1) -> tuple[DenseInputs, Vocabulary]:
    """Read a part through ``EpisodeDataset`` (only its single-step episodes if asked, the
    first ``limit``) and encode it as :func:`encode_items` does; ``workers`` > 1 reads
    contiguous chunks in that many spawned processes (the result is the same)."""
    from nsrmp_bench.dataset import EpisodeDataset

    ds = EpisodeDataset(path)
    index = ds.collection.index
    rows = (list(np.flatnonzero(index["steps"].to_numpy() == 1)) if single_step
            else list(range(len(ds))))
    if limit is not None:
        rows = rows[:limit]
    rows = [int(i) for i in rows]
    if workers <= 1 or len(rows) < 100:
        return encode_items((ds[i] for i in rows), vocab, scale, targets=targets)
    import multiprocessing

    size = -(-len(rows) // (4 * workers))
    jobs = [(str(path), rows[k:k + size], scale, targets) for k in range(0, len(rows), size)]
    with multiprocessing.get_context("spawn").Pool(workers) as pool:
        records = [r for chunk in pool.map(_read_chunk, jobs) for r in chunk]
    return _assemble(records, vocab, scale, targets)
