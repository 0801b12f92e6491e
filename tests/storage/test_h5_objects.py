"""h5_objects makes the same file, byte for byte, as h5py's high-level calls it replaces;
what it does not cover is refused by name.

The whole writer's bytes are checked against the committed shard in
``test_writer_background.py``; here each kind of object the layout stores is compared on
its own, so a difference names the object."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import h5_objects
from nsrmp_bench.storage.layout import LIBVER, image_codec, small_codec

RNG = np.random.default_rng(7)
RGB = RNG.integers(0, 255, (3, 24, 32, 3), dtype=np.uint8)
DEPTH = RNG.random((3, 24, 32), dtype=np.float32)
SEG = RNG.integers(-1, 9, (4, 24, 32), dtype=np.int16)
SMALL: dict[str, np.ndarray[Any, Any]] = {"poses": RNG.random((4, 5, 7)), "boxes": RNG.random((5, 4)).astype(np.float32),
         "step": np.arange(6, dtype=np.int16), "empty": np.zeros((0, 7)),
         "flags": np.array([True, False, True])}
ATTRS: dict[str, Any] = {"id": "paper-v2/test/000001", "index": np.int64(12),
                         "has_images": np.bool_(True), "seed": '{"index":1,"é":"ü"}'}


def _file_bytes(tmp_path: Path, name: str, fill: Callable[[h5py.File], None]) -> bytes:
    path = tmp_path / f"{name}.h5"
    with h5py.File(path, "w", libver=LIBVER) as f:
        fill(f)
        f.flush()
    return path.read_bytes()


def _high_level(f: h5py.File) -> None:
    gcpl = h5py.h5p.create(h5py.h5p.GROUP_CREATE)
    gcpl.set_obj_track_times(False)
    g = h5py.Group(h5py.h5g.create(f.id, b"episode", gcpl=gcpl))
    for key, value in ATTRS.items():
        g.attrs[key] = value
    for name, arr, stacked in (("rgb0", RGB[0], False), ("rgb", RGB, True),
                               ("depth0", DEPTH[0], False), ("depth", DEPTH, True),
                               ("segmentation", SEG, True)):
        kw = image_codec(arr.shape, arr.dtype, stacked=stacked)
        g.create_dataset(name, data=arr, track_times=False, **kw)
    for name, arr in SMALL.items():
        g.create_dataset(name, data=arr, track_times=False, **small_codec())
    text = h5py.string_dtype("utf-8")
    g.create_dataset("program", data=np.array("pick(x) → place(y)", dtype=text), dtype=text,
                     track_times=False)


def _low_level(f: h5py.File) -> None:
    g = h5_objects.group(f.id, "episode")
    for key, value in ATTRS.items():
        h5_objects.attribute(g, key, value)
    for name, arr, stacked in (("rgb0", RGB[0], False), ("rgb", RGB, True),
                               ("depth0", DEPTH[0], False), ("depth", DEPTH, True),
                               ("segmentation", SEG, True)):
        h5_objects.dataset(g, name, arr, image_codec(arr.shape, arr.dtype, stacked=stacked))
    for name, arr in SMALL.items():
        h5_objects.dataset(g, name, arr, small_codec())
    h5_objects.string_dataset(g, "program", "pick(x) → place(y)")


def test_same_bytes_as_h5py_high_level(tmp_path: Path) -> None:
    expected = _file_bytes(tmp_path, "high", _high_level)
    # twice: the second time every property list, type and dataspace comes from the cache
    assert _file_bytes(tmp_path, "low", _low_level) == expected
    assert _file_bytes(tmp_path, "low-again", _low_level) == expected


def test_values_read_back_by_plain_h5py(tmp_path: Path) -> None:
    _file_bytes(tmp_path, "low", _low_level)
    with h5py.File(tmp_path / "low.h5", "r") as f:
        g = f["episode"]
        assert g.attrs["id"] == ATTRS["id"] and g.attrs["index"] == 12
        assert g.attrs["seed"] == ATTRS["seed"] and bool(g.attrs["has_images"])
        np.testing.assert_array_equal(g["depth"][()], DEPTH)
        assert g["depth"].compression == "gzip" and g["depth"].shuffle
        assert g["depth"].chunks == (1, 24, 32) and g["rgb0"].chunks == (24, 32, 3)
        np.testing.assert_array_equal(g["segmentation"][()], SEG)
        np.testing.assert_array_equal(g["flags"][()], SMALL["flags"])
        assert g["empty"].shape == (0, 7) and g["poses"].chunks is None
        assert g["program"][()].decode("utf-8") == "pick(x) → place(y)"
        assert g["program"].shape == ()


@pytest.mark.parametrize(("call", "named"), [
    (lambda g: h5_objects.dataset(g, "a", RGB, {"compression": "lzf"}), "'lzf'"),
    (lambda g: h5_objects.dataset(g, "a", RGB, {"chunks": RGB.shape, "fletcher32": True}),
     "fletcher32"),
    (lambda g: h5_objects.dataset(g, "a", np.array(3.0), {"chunks": ()}), "scalar"),
    (lambda g: h5_objects.dataset(g, "a", np.array([b"ab"]), {}), "S2"),
    (lambda g: h5_objects.dataset(g, "a", np.array([{}], dtype=object), {}), "object"),
    (lambda g: h5_objects.attribute(g, "a", np.arange(3)), "shape (3,)"),  # type: ignore[arg-type]
    (lambda g: h5_objects.dataset(g, "a", np.array("x", dtype=h5py.string_dtype("ascii")), {}),
     "ascii"),
])
def test_refuses_what_it_does_not_cover(tmp_path: Path, call: Callable[[Any], None],
                                        named: str) -> None:
    with h5py.File(tmp_path / "refused.h5", "w", libver=LIBVER) as f:
        with pytest.raises(InvalidArgument, match=re.escape(named)):
            call(f.id)
        assert "a" not in f  # nothing half-made
