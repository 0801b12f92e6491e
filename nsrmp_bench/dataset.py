"""A PyTorch ``Dataset`` over stored episodes (torch extra).

Each item keeps what a model may read apart from the gold::

    {"id": str, "index": int,
     "inputs":  {"instruction": str, "rgb": uint8 (H, W, 3), "depth": float32 (H, W),
                 "boxes": float32 (N, 4) amodal pixel xyxy of the initial state,
                 "camera": Camera (the episode's; None for an episode without rendering)},
     "targets": {"boxes": float32 (S+1, N, 4), "final_boxes": float32 (N, 4),
                 "poses": float32 (S+1, N, 7), "grounded": int64 (S, 3)
                 [action index in ACTIONS, subject, reference], "moved": bool (N,),
                 "shapes": int64 (N,) index in SHAPES, "colours": int64 (N,) index in
                 COLOURS, "program": list of node dicts, "program_text": str,
                 "rgb": uint8 (S, H, W, 3) the render after each step (with
                 ``step_images=True``, else None)}}

An inputs-only part (``pack --inputs-only``) gives ``"targets": None``.

A model reads ``inputs`` only (:func:`item_camera` and :func:`shared_camera` give the
camera, typed); ``targets`` reach only its loss. Images stay ``uint8``/``float32`` tensors:
normalise on the accelerator. Files are opened lazily in each worker process (the
collection checks the pid), so ``num_workers`` 0 or more works, with fork or spawn.
:func:`collate_episodes` pads objects and steps and returns masks.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.storage.reader import EpisodeCollection, input_camera
from nsrmp_bench.storage.reader import open as open_collection
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, SHAPES

if TYPE_CHECKING:
    from torch import Tensor
    from torch.utils.data import DataLoader

torch = require("torch")

__all__ = ["EpisodeDataset", "collate_episodes", "data_loader", "item_camera", "shared_camera"]

_ACTION_INDEX = {a: i for i, a in enumerate(ACTIONS)}
_SHAPE_INDEX = {s: i for i, s in enumerate(SHAPES)}
_COLOUR_INDEX = {c: i for i, c in enumerate(COLOURS)}


class EpisodeDataset:
    """Map-style dataset of episodes: ``len(ds)`` and ``ds[i]`` (a dict, see module doc).

    ``source`` is a shard file, a data directory or an open :class:`EpisodeCollection`.
    With ``images=False`` the RGB/depth entries are None (symbolic and box models);
    ``step_images=True`` adds the render after each step to the targets (models that
    learn to draw them). ``transform`` is applied to each item.
    """

    def __init__(
        self,
        source: str | os.PathLike[str] | EpisodeCollection,
        *,
        images: bool = True,
        step_images: bool = False,
        transform: Callable[[dict[str, Any]], dict[str, Any]] | None = None,
    ) -> None:
        if isinstance(source, EpisodeCollection):
            self.collection = source
        else:
            self.collection = open_collection(source)
        self.collection.close()  # never hand an open HDF5 handle to forked workers
        self.images = images
        self.step_images = step_images
        self.transform = transform

    def __len__(self) -> int:
        return len(self.collection)

    def iter_items(self, limit: int = 0, *, start: int = 0) -> Iterator[dict[str, Any]]:
        """The items from position ``start`` on, read one at a time: ``limit`` of them (0: to
        the end; fewer where the dataset ends first)."""
        stop = len(self) if limit <= 0 else min(start + limit, len(self))
        return (self[i] for i in range(start, stop))

    def __getitem__(self, i: int) -> dict[str, Any]:
        arrays = ("poses", "boxes", "rgb") if self.step_images else ("poses", "boxes")
        inp, tg = self.collection.read_item(i, images=self.images, arrays=arrays)
        inputs = {
            "instruction": inp["instruction"],
            "rgb": _tensor(inp["rgb"]),
            "depth": _tensor(inp["depth"]),
            "boxes": _tensor(inp["boxes"]),
            "camera": inp["camera"],
        }
        if tg is None:  # an inputs-only part: no gold to read
            bare: dict[str, Any] = {"id": inp["id"], "index": self.collection.instance_index(i),
                                    "inputs": inputs, "targets": None}
            return self.transform(bare) if self.transform is not None else bare
        sym = tg["symbolic"]
        objects = sym["scene"]["objects"]
        n = len(objects)
        grounded = np.array(
            [[_ACTION_INDEX[a], s, r] for a, s, r in sym["grounded"]], dtype=np.int64
        ).reshape(-1, 3)
        moved = np.zeros(n, dtype=bool)
        moved[grounded[:, 1]] = True
        boxes = tg["boxes"]
        item: dict[str, Any] = {
            "id": inp["id"],
            "index": int(sym["seed"]["index"]),
            "inputs": inputs,
            "targets": {
                "boxes": _tensor(boxes),
                "final_boxes": _tensor(boxes[-1] if boxes is not None else None),
                "poses": _tensor(tg["poses"].astype(np.float32)
                                 if tg["poses"] is not None else None),
                "grounded": torch.from_numpy(grounded),
                "moved": torch.from_numpy(moved),
                "shapes": torch.tensor([_SHAPE_INDEX[o["shape"]] for o in objects],
                                       dtype=torch.int64),
                "colours": torch.tensor([_COLOUR_INDEX[o["colour"]] for o in objects],
                                        dtype=torch.int64),
                "program": sym["program"],
                "program_text": tg["program"],
                "rgb": _tensor(tg["rgb"]) if self.step_images else None,
            },
        }
        return self.transform(item) if self.transform is not None else item


def item_camera(item: Mapping[str, Any]) -> Camera:
    """The camera of a dataset item (its ``inputs``); an error for an episode without one."""
    return input_camera(item["inputs"], item.get("id"))


def shared_camera(items: Sequence[Mapping[str, Any]]) -> Camera:
    """The one camera of ``items`` (every episode of a split part shares it): for what a
    model computes once per batch, such as the predictions writer's back-projection.

    An empty batch, an episode without a camera, or two cameras are errors.
    """
    if not items:
        msg = "no items given: pass at least one dataset item to take the camera from"
        raise InvalidArgument(msg)
    first = item_camera(items[0])
    for item in items[1:]:
        camera = item_camera(item)
        if camera != first:
            msg = (f"episode {item.get('id')!r} has another camera than episode "
                   f"{items[0].get('id')!r} ({camera} against {first}); a batch reads one "
                   "camera: predict each split part on its own")
            raise InvalidArgument(msg)
    return first


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
    poses with 0, grounded steps, shapes and colours with -1); ``object_mask`` (B, N),
    ``state_mask`` (B, S+1) and ``step_mask`` (B, S) say what is real, ``has_rendering``
    (B,) which items have boxes and poses at all. Initial images are stacked when all are
    present and of one size, else kept as a list. Cameras, the renders after each step,
    programs and texts stay lists.
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
            "camera": [x["camera"] for x in inputs],
        },
        "targets": {
            "boxes": _pad([t["boxes"] for t in targets], (smax + 1, nmax, 4), 0.0),
            "final_boxes": _pad([t["final_boxes"] for t in targets], (nmax, 4), 0.0),
            "poses": _pad([t["poses"] for t in targets], (smax + 1, nmax, 7), 0.0),
            "grounded": _pad([t["grounded"] for t in targets], (smax, 3), -1),
            "moved": _pad([t["moved"] for t in targets], (nmax,), False),
            "shapes": _pad([t["shapes"] for t in targets], (nmax,), -1),
            "colours": _pad([t["colours"] for t in targets], (nmax,), -1),
            "program": [t["program"] for t in targets],
            "program_text": [t["program_text"] for t in targets],
            "rgb": [t["rgb"] for t in targets],
        },
    }


def data_loader(dataset: EpisodeDataset, **kwargs: Any) -> DataLoader[Any]:
    """A ``torch.utils.data.DataLoader`` with :func:`collate_episodes` (kwargs pass through)."""
    kwargs.setdefault("collate_fn", collate_episodes)
    if kwargs.get("num_workers", 0) > 0:
        kwargs.setdefault("persistent_workers", True)
    loader: DataLoader[Any] = torch.utils.data.DataLoader(dataset, **kwargs)
    return loader
