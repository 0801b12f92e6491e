"""Image chunks through the format's filters in Python are the chunks HDF5 itself stores;
the chunk walk refuses shapes it does not cover; precompress stops when told."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.chunks import filtered_chunk, image_chunks, image_datasets, precompress
from nsrmp_bench.storage.layout import image_codec


def _arrays(states: int = 3, seed: int = 0) -> dict[str, np.ndarray[Any, Any]]:
    """Image arrays like a rendering's: smooth enough to compress, with noise in them."""
    rng = np.random.default_rng(seed)
    h, w = 24, 32
    ramp = np.linspace(0.5, 1.5, h * w, dtype=np.float32).reshape(h, w)
    return {
        "observations/rgb": rng.integers(0, 256, (states, h, w, 3), dtype=np.uint8) // 16 * 16,
        "observations/depth": (ramp + rng.normal(0, 1e-3, (states, h, w))).astype(np.float32),
        "observations/segmentation": rng.integers(-1, 4, (states, h, w)).astype(np.int16),
    }


def test_filtered_chunks_are_the_chunks_hdf5_stores(tmp_path: Path) -> None:
    arrays = _arrays()
    with h5py.File(tmp_path / "hdf5.h5", "w") as f:
        for path, name, arr, kw in image_datasets(arrays):
            ds = f.create_dataset(f"{path}/{name}", data=arr, **kw)  # HDF5's own filters
            for k, offset, chunk in image_chunks(arr, kw):
                mask, stored = ds.id.read_direct_chunk(offset)
                assert mask == 0
                assert filtered_chunk(chunk, kw) == stored, (path, name, k)


def test_image_datasets_are_listed_in_writing_order() -> None:
    listed = [(path, name, arr.shape) for path, name, arr, _ in image_datasets(_arrays(3))]
    assert listed == [("inputs/obs", "rgb", (24, 32, 3)), ("targets/obs", "rgb", (2, 24, 32, 3)),
                      ("inputs/obs", "depth", (24, 32)), ("targets/obs", "depth", (2, 24, 32)),
                      ("targets/obs", "segmentation", (3, 24, 32))]
    assert image_datasets({}) == []


def test_other_chunk_shapes_are_refused_by_name() -> None:
    arr = np.zeros((2, 24, 32), np.float32)
    kw = {**image_codec(arr.shape, arr.dtype, stacked=True), "chunks": (2, 12, 32)}
    with pytest.raises(InvalidArgument, match=r"got chunks \(2, 12, 32\) for an array of "
                                              r"shape \(2, 24, 32\)"):
        list(image_chunks(arr, kw))


def test_precompress_stops_when_told_and_keys_chunks_by_dataset_and_index() -> None:
    arrays = _arrays(3)
    asked = 0

    def until() -> bool:
        nonlocal asked
        asked += 1
        return asked > 4

    some = precompress(arrays, until)
    assert list(some) == [("inputs/obs/rgb", 0), ("targets/obs/rgb", 0), ("targets/obs/rgb", 1),
                          ("inputs/obs/depth", 0)]
    every = precompress(arrays, lambda: False)
    assert len(every) == 3 * 3  # rgb, depth, segmentation for every state
    rgb = arrays["observations/rgb"][1:]
    kw = image_codec(rgb.shape, rgb.dtype, stacked=True)
    assert every[("targets/obs/rgb", 1)].tobytes() == filtered_chunk(rgb[1:2], kw)
