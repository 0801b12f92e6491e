"""An episode's image datasets and their chunks through the format's filters.

Every image dataset of a shard (:func:`~nsrmp_bench.storage.layout.image_codec`) is stored
one image per chunk, byte-shuffled when it holds floats, then DEFLATE level 1.
:func:`filtered_chunk` runs that pipeline in Python (``zlib`` lets go of the GIL, unlike
HDF5's filter called through h5py) and gives the bytes HDF5 itself would store, so a chunk
compressed here and written with ``write_direct_chunk`` makes the same file.

:func:`precompress` is how a process that hands its episodes to a writer process takes
part of the writer's work when the writer lags behind: it compresses chunks while it
would otherwise wait for a free slot, and the writer stores them as they are
(:mod:`~nsrmp_bench.storage.writer`).
"""

from __future__ import annotations

import zlib
from collections.abc import Callable, Iterator, Mapping
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.layout import image_codec
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater

__all__ = ["ChunkKey", "Compressed", "filtered_chunk", "has_filtered_chunks", "image_chunks",
           "image_datasets", "precompress"]

ChunkKey: TypeAlias = tuple[str, int]
"""(the dataset's path in the episode group, e.g. ``targets/obs/rgb``; the chunk's index
along the first axis, 0 for a single image)."""

Compressed: TypeAlias = dict[ChunkKey, NDArray[np.uint8]]
"""Chunks already through the filters, by key; what the writer stores as they are."""


def filtered_chunk(chunk: NDArray[Any], kw: Mapping[str, Any],
                   deflater: PrefixDeflater | None = None) -> bytes:
    """``chunk`` through the filter pipeline of an :func:`image_codec` dataset: byte
    shuffle (when ``kw["shuffle"]``), then DEFLATE at ``kw["compression_opts"]``, as
    HDF5's H5Z_SHUFFLE and H5Z_DEFLATE (``compress2``) do.

    With a ``deflater``, a chunk that is not shuffled (RGB, segmentation) is compressed
    by it: the same bytes, resumed after the rows it shares with the learnt background
    (:mod:`~nsrmp_bench.storage.prefix_deflate`). A shuffled chunk shares only part of its
    first byte plane with the background, which saved too little to pay for the
    checkpoints (measured: 5% of a depth chunk's DEFLATE, against 15-25% of an RGB one)."""
    data = np.ascontiguousarray(chunk)
    level = int(kw["compression_opts"])
    shuffle = bool(kw.get("shuffle"))
    if not shuffle and deflater is not None:
        return deflater.compress(data.tobytes(), level, data.dtype.str)
    if shuffle and data.size > 1:
        raw = data.view(np.uint8).reshape(data.size, data.dtype.itemsize).T.tobytes()
    else:
        raw = data.tobytes()
    return zlib.compress(raw, level)


def image_datasets(arrays: Mapping[str, NDArray[Any]]
                   ) -> list[tuple[str, str, NDArray[Any], dict[str, Any]]]:
    """(group path, name, array, h5py keywords) of each image dataset of an episode, given
    its :func:`~nsrmp_bench.storage.arrays.episode_arrays`, in the order they are written:
    the first state's RGB and depth under ``inputs/obs``, the later states' and every
    state's segmentation under ``targets/obs``. Empty when the episode has no images."""
    if "observations/rgb" not in arrays:
        return []
    out: list[tuple[str, str, NDArray[Any], dict[str, Any]]] = []
    for key in ("rgb", "depth"):
        arr = arrays[f"observations/{key}"]
        first, later = arr[0], arr[1:]
        out.append(("inputs/obs", key, first,
                    image_codec(first.shape, first.dtype, stacked=False)))
        out.append(("targets/obs", key, later,
                    image_codec(later.shape, later.dtype, stacked=True)))
    seg = arrays["observations/segmentation"]
    out.append(("targets/obs", "segmentation", seg,
                image_codec(seg.shape, seg.dtype, stacked=True)))
    return out


def has_filtered_chunks(kw: Mapping[str, Any]) -> bool:
    """Whether a dataset made with these h5py keywords stores chunks through the filters
    (an empty stack's :func:`image_codec` has neither chunks nor filters)."""
    return kw.get("compression") == "gzip"


def image_chunks(arr: NDArray[Any], kw: Mapping[str, Any]
                 ) -> Iterator[tuple[int, tuple[int, ...], NDArray[Any]]]:
    """(index, offset, chunk) of each chunk of an :func:`image_codec` dataset holding
    ``arr``: the whole array when its chunk is the array, else one image per chunk. Other
    chunk shapes are refused, naming them."""
    chunks = tuple(kw["chunks"])
    if chunks == arr.shape:
        yield 0, (0,) * arr.ndim, arr
        return
    if chunks != (1, *arr.shape[1:]):
        msg = (f"direct chunk writes take one image or one image per chunk, got chunks "
               f"{chunks} for an array of shape {arr.shape}")
        raise InvalidArgument(msg)
    for k in range(arr.shape[0]):
        yield k, (k,) + (0,) * (arr.ndim - 1), arr[k:k + 1]


def precompress(arrays: Mapping[str, NDArray[Any]], until: Callable[[], bool], *,
                max_bytes: int | None = None,
                deflater: PrefixDeflater | None = None) -> Compressed:
    """Compress an episode's image chunks, in writing order, one at a time until
    ``until()`` says to stop (it is asked before each chunk), the next chunk would take
    the compressed bytes past ``max_bytes``, or all are done; with ``deflater`` as
    :func:`filtered_chunk` does (the episode is a new one to it)."""
    if deflater is not None:
        deflater.next_episode()
    out: Compressed = {}
    total = 0
    for path, name, arr, kw in image_datasets(arrays):
        if not has_filtered_chunks(kw):
            continue
        for k, _, chunk in image_chunks(arr, kw):
            if until():
                return out
            data = filtered_chunk(chunk, kw, deflater)
            total += len(data)
            if max_bytes is not None and total > max_bytes:
                return out
            out[(f"{path}/{name}", k)] = np.frombuffer(data, np.uint8)
    return out
