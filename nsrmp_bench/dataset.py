"""A PyTorch ``Dataset`` over stored episodes (torch extra).

Each item keeps what a model may read apart from the gold::

    {"id": str, "index": int,
     "inputs":  {"instruction": str, "rgb": uint8 (H, W, 3), "depth": float32 (H, W),
                 "boxes": float32 (N, 4) amodal pixel xyxy of the initial state},
     "targets": {"boxes": float32 (S+1, N, 4), "final_boxes": float32 (N, 4),
                 "poses": float32 (S+1, N, 7), "grounded": int64 (S, 3)
                 [action index in ACTIONS, subject, reference], "moved": bool (N,),
                 "program": list of node dicts, "program_text": str}}

Images stay ``uint8``/``float32`` tensors: normalise on the accelerator. Files are opened
lazily in each worker process (the collection checks the pid), so ``num_workers`` 0 or
more works, with fork or spawn. :func:`collate_episodes` pads objects and steps and
returns masks.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from nsrmp_bench._optional import require
from nsrmp_bench.storage.reader import EpisodeCollection
from nsrmp_bench.storage.reader import open as open_collection
from nsrmp_bench.vocabulary import ACTIONS

if TYPE_CHECKING:
    from torch import Tensor
    from torch.utils.data import DataLoader

torch = require("torch")

__all__ = ["EpisodeDataset", "collate_episodes", "data_loader"]

_ACTION_INDEX = {a: i for i, a in enumerate(ACTIONS)}


class EpisodeDataset:
    """Map-style dataset of episodes: ``len(ds)`` and ``ds[i]`` (a dict, see module doc).

    ``source`` is a shard file, a data directory or an open :class:`EpisodeCollection`.
    With ``images=False`` the RGB/depth entries are None (symbolic and box models).
    ``transform`` is applied to each item.
    """

    def __init__(
        self,
        source: str | os.PathLike[str] | EpisodeCollection,
        *,
        images: bool = True,
        transform: Callable[[dict[str, Any]], dict[str, Any]] | None = None,
    ) -> None:
        if isinstance(source, EpisodeCollection):
            self.collection = source
        else:
            self.collection = open_collection(source)
        self.collection.close()  # never hand an open HDF5 handle to forked workers
        self.images = images
        self.transform = transform

    def __len__(self) -> int:
        return len(self.collection)

    def __getitem__(self, i: int) -> dict[str, Any]:
        inp, tg = self.collection.read_item(i, images=self.images, arrays=("poses", "boxes"))
        sym = tg["symbolic"]
        n = len(sym["scene"]["objects"])
        grounded = np.array(
            [[_ACTION_INDEX[a], s, r] for a, s, r in sym["grounded"]], dtype=np.int64
        ).reshape(-1, 3)
        moved = np.zeros(n, dtype=bool)
        moved[grounded[:, 1]] = True
        boxes = tg["boxes"]
        item: dict[str, Any] = {
            "id": inp["id"],
            "index": int(sym["seed"]["index"]),
            "inputs": {
                "instruction": inp["instruction"],
                "rgb": _tensor(inp["rgb"]),
                "depth": _tensor(inp["depth"]),
                "boxes": _tensor(inp["boxes"]),
            },
            "targets": {
                "boxes": _tensor(boxes),
                "final_boxes": _tensor(boxes[-1] if boxes is not None else None),
                "poses": _tensor(tg["poses"].astype(np.float32)
                                 if tg["poses"] is not None else None),
                "grounded": torch.from_numpy(grounded),
                "moved": torch.from_numpy(moved),
                "program": sym["program"],
                "program_text": tg["program"],
            },
        }
        return self.transform(item) if self.transform is not None else item


def _tensor(arr: np.ndarray[Any, Any] | None) -> Tensor | None:
    return None if arr is None else torch.from_numpy(np.ascontiguousarray(arr))


def _pad(values: Sequence[Tensor | None], shape: tuple[int, ...], fill: float) -> Tensor | None:
    """Stack tensors of varying leading sizes into ``(B, *shape)``, padded with ``fill``.

    A None entry (an episode without rendering) becomes all padding; None if all are None.
    """
    present = [v for v in values if v is not None]
    if not present:
        return None
    out = torch.full((len(values), *shape), fill, dtype=present[0].dtype)
    for b, v in enumerate(values):
        if v is not None:
            out[(b, *(slice(0, d) for d in v.shape))] = v
    return out  # type: ignore[no-any-return]


def _stack_images(values: Sequence[Tensor | None]) -> Tensor | list[Tensor | None]:
    present = [v for v in values if v is not None]
    if len(present) == len(values) and len({tuple(v.shape) for v in present}) == 1:
        return torch.stack(present)  # type: ignore[no-any-return]
    return list(values)


def collate_episodes(items: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Batch items of varying object and step counts.

    Boxes and poses are padded to the batch's largest N objects and S+1 states (boxes and
    poses with 0, grounded steps with -1); ``object_mask`` (B, N), ``state_mask`` (B, S+1)
    and ``step_mask`` (B, S) say what is real, ``has_rendering`` (B,) which items have boxes
    and poses at all. Images are stacked when all are present and
    of one size, else kept as a list. Programs and texts stay lists.
    """
    inputs = [it["inputs"] for it in items]
    targets = [it["targets"] for it in items]
    n_obj = [len(t["moved"]) for t in targets]
    n_steps = [len(t["grounded"]) for t in targets]
    b, nmax, smax = len(items), max(n_obj, default=0), max(n_steps, default=0)
    object_mask = torch.zeros((b, nmax), dtype=torch.bool)
    state_mask = torch.zeros((b, smax + 1), dtype=torch.bool)
    step_mask = torch.zeros((b, smax), dtype=torch.bool)
    for i, (n, s) in enumerate(zip(n_obj, n_steps, strict=True)):
        object_mask[i, :n] = True
        state_mask[i, : s + 1] = True
        step_mask[i, :s] = True
    has_rendering = torch.tensor([t["boxes"] is not None for t in targets], dtype=torch.bool)
    return {
        "id": [it["id"] for it in items],
        "has_rendering": has_rendering,
        "index": torch.tensor([it["index"] for it in items], dtype=torch.int64),
        "object_mask": object_mask,
        "state_mask": state_mask,
        "step_mask": step_mask,
        "inputs": {
            "instruction": [x["instruction"] for x in inputs],
            "rgb": _stack_images([x["rgb"] for x in inputs]),
            "depth": _stack_images([x["depth"] for x in inputs]),
            "boxes": _pad([x["boxes"] for x in inputs], (nmax, 4), 0.0),
        },
        "targets": {
            "boxes": _pad([t["boxes"] for t in targets], (smax + 1, nmax, 4), 0.0),
            "final_boxes": _pad([t["final_boxes"] for t in targets], (nmax, 4), 0.0),
            "poses": _pad([t["poses"] for t in targets], (smax + 1, nmax, 7), 0.0),
            "grounded": _pad([t["grounded"] for t in targets], (smax, 3), -1),
            "moved": _pad([t["moved"] for t in targets], (nmax,), False),
            "program": [t["program"] for t in targets],
            "program_text": [t["program_text"] for t in targets],
        },
    }


def data_loader(dataset: EpisodeDataset, **kwargs: Any) -> DataLoader[Any]:
    """A ``torch.utils.data.DataLoader`` with :func:`collate_episodes` (kwargs pass through)."""
    kwargs.setdefault("collate_fn", collate_episodes)
    if kwargs.get("num_workers", 0) > 0:
        kwargs.setdefault("persistent_workers", True)
    loader: DataLoader[Any] = torch.utils.data.DataLoader(dataset, **kwargs)
    return loader
