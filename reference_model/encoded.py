"""A split part encoded once into padded tensors: what the object-centric models train on.

:func:`encode_inputs` reads only the ``inputs`` of each item (instruction, initial RGB,
depth and boxes), so prediction works on a dataset whose targets cannot be read.
:func:`encode_targets` adds the supervision (final boxes) and the categories the curriculum
selects on (steps, relational, phrasing: the split's own index, not the model's inputs).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
import torch
from numpy.typing import ArrayLike
from torch import Tensor

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.instruction_check import check_instruction
from nsrmp_bench.reference_model.features import CROP, GEOMETRY, object_inputs
from nsrmp_bench.reference_model.tokens import PAD, Vocabulary

__all__ = ["Encoded", "encode_inputs", "encode_part", "encode_targets", "encode_train_val"]


@dataclass
class Encoded:
    """Padded tensors of E episodes with at most N objects and T tokens."""

    ids: list[str]
    texts: list[str]
    tokens: Tensor  # (E, T) int64, PAD-padded
    crops: Tensor  # (E, N, 3, CROP, CROP) uint8
    geometry: Tensor  # (E, N, 5) float32
    boxes: Tensor  # (E, N, 4) float32 initial pixel xyxy
    object_mask: Tensor  # (E, N) bool
    image_size: tuple[int, int]
    final_boxes: Tensor | None = None  # (E, N, 4)
    meta: dict[str, Tensor] = field(default_factory=dict)  # steps, relational, phrasing

    def __len__(self) -> int:
        return len(self.ids)

    def select(self, rows: Sequence[int] | Tensor) -> Encoded:
        """The episodes at ``rows``, trimmed to their longest object list and text."""
        idx = torch.as_tensor(rows, dtype=torch.long)
        om = self.object_mask[idx]
        n = max(1, int(om.sum(1).max())) if len(idx) else 1
        tok = self.tokens[idx]
        t = max(1, int((tok != PAD).sum(1).max())) if len(idx) else 1
        return Encoded(
            ids=[self.ids[i] for i in idx.tolist()],
            texts=[self.texts[i] for i in idx.tolist()],
            tokens=tok[:, :t], crops=self.crops[idx, :n], geometry=self.geometry[idx, :n],
            boxes=self.boxes[idx, :n], object_mask=om[:, :n], image_size=self.image_size,
            final_boxes=None if self.final_boxes is None else self.final_boxes[idx, :n],
            meta={k: v[idx] for k, v in self.meta.items()},
        )


def encode_inputs(items: Iterable[Mapping[str, Any]], vocab: Vocabulary) -> Encoded:
    """Encode the ``inputs`` of dataset items (``{"id", "inputs": {...}}``)."""
    ids: list[str] = []
    texts: list[str] = []
    objs = []
    for item in items:
        inp = item["inputs"]
        if inp.get("rgb") is None or inp.get("boxes") is None:
            msg = (
                f"episode {item['id']!r} has no rendering (RGB and boxes); the object models "
                "read the initial image and boxes: generate the split with rendering"
            )
            raise InvalidArgument(msg)
        ids.append(str(item["id"]))
        texts.append(check_instruction(inp.get("instruction"),
                                       f"the instruction of episode {item['id']!r}"))
        objs.append(object_inputs(_np(inp["rgb"]), _np(inp["depth"]), _np(inp["boxes"])))
    if not objs:
        msg = "no episodes to encode; the data holds no episodes"
        raise InvalidArgument(msg)
    e = len(objs)
    n = max(len(o.boxes) for o in objs)
    enc = [vocab.encode(t) or [PAD] for t in texts]
    t = max(len(x) for x in enc)
    tokens = torch.full((e, t), PAD, dtype=torch.long)
    crops = torch.zeros((e, n, 3, CROP, CROP), dtype=torch.uint8)
    geometry = torch.zeros((e, n, GEOMETRY), dtype=torch.float32)
    boxes = torch.zeros((e, n, 4), dtype=torch.float32)
    mask = torch.zeros((e, n), dtype=torch.bool)
    for i, (o, x) in enumerate(zip(objs, enc, strict=True)):
        k = len(o.boxes)
        tokens[i, : len(x)] = torch.tensor(x)
        crops[i, :k] = torch.from_numpy(o.crops)
        geometry[i, :k] = torch.from_numpy(o.geometry)
        boxes[i, :k] = torch.from_numpy(o.boxes)
        mask[i, :k] = True
    return Encoded(ids, texts, tokens, crops, geometry, boxes, mask, objs[0].image_size)


def encode_targets(enc: Encoded, items: Iterable[Mapping[str, Any]],
                   categories: Mapping[str, Mapping[str, Any]]) -> Encoded:
    """Add final boxes and curriculum categories (by episode id) to ``enc`` in place."""
    final = torch.zeros_like(enc.boxes)
    for i, item in enumerate(items):
        fb = _np(item["targets"]["final_boxes"])
        final[i, : len(fb)] = torch.from_numpy(np.asarray(fb, dtype=np.float32))
    enc.final_boxes = final
    phr = {"simple": 0, "complex": 1, "compound": 2}
    enc.meta = {
        "steps": torch.tensor([int(categories[i]["steps"]) for i in enc.ids]),
        "relational": torch.tensor([bool(categories[i]["relational"]) for i in enc.ids]),
        "phrasing": torch.tensor([phr.get(str(categories[i]["phrasing"]), 0) for i in enc.ids]),
    }
    return enc


def _np(x: Tensor | ArrayLike) -> np.ndarray[Any, Any]:
    return x.numpy() if isinstance(x, Tensor) else np.asarray(x)


def encode_part(path: str | Path, vocab: Vocabulary | None = None, *, targets: bool
                ) -> tuple[Encoded, Vocabulary]:
    """Read a data directory (one split part) through ``EpisodeDataset`` and encode it.

    Without ``vocab`` the vocabulary is built from this part's instructions (training).
    """
    from nsrmp_bench.dataset import EpisodeDataset

    ds = EpisodeDataset(path)
    items = [ds[i] for i in range(len(ds))]
    if vocab is None:
        vocab = Vocabulary.build(check_instruction(it["inputs"].get("instruction"),
                                                   f"the instruction of episode {it['id']!r}")
                                 for it in items)
    enc = encode_inputs(items, vocab)
    if targets:
        cats = ds.collection.index.set_index("id").to_dict("index")
        encode_targets(enc, items, cast(Mapping[str, Mapping[str, Any]], cats))
    return enc, vocab


def encode_train_val(data: Path) -> tuple[Encoded, Encoded, Vocabulary]:
    """A split root's training and selection episodes, with targets, and the vocabulary
    built from the training part.

    A split without a val part (attributes-v2) selects on the last tenth of its train part,
    which is then not trained on.
    """
    if not (data / "train" / "manifest.json").exists():
        msg = (f"{data} has no finished part 'train' ({data / 'train'}); pass a split root "
               "holding train/ (and val/), e.g. generate one with `nsrmp-bench generate "
               "--split paper-v2 --out data/paper-v2`")
        raise InvalidArgument(msg)
    train, vocab = encode_part(data / "train", targets=True)
    if (data / "val" / "manifest.json").exists():
        val, _ = encode_part(data / "val", vocab, targets=True)
    else:
        cut = len(train) - max(1, len(train) // 10)
        train, val = train.select(range(cut)), train.select(range(cut, len(train)))
    return train, val, vocab
