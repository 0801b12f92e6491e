"""Creating HDF5 groups, datasets and attributes through h5py's low-level API.

A shard's writer creates, per episode, about 16 datasets, 5 groups and 11 attributes.
h5py's high-level calls (``Group.create_dataset``, ``attrs[name] = value``) check their
arguments in Python and build a new property list, datatype and dataspace for every
one: about 2 ms of the writer's 17.8 ms of CPU per episode at 320x240
(``docs/performance.md``; ``benchmarks/bench_generate.py --writer`` prints what is left).
The functions here make the same HDF5 calls with the same arguments as those
high-level calls (``H5Dcreate`` with the same creation property list: chunks, byte
shuffle, DEFLATE level, no time tracking, then one whole write; ``H5Acreate`` then one
write; ``H5Gcreate`` without time tracking), but build the property lists, datatypes and
dataspaces once per process and reuse them. So a file's bytes do not change
(``tests/storage/test_h5_objects.py`` compares them with h5py's high-level calls, and the
writer tests whole shards with the committed one).

Only what the layout uses is taken: the codecs of :func:`~nsrmp_bench.storage.layout.
image_codec` and :func:`~nsrmp_bench.storage.layout.small_codec`, numeric and boolean
arrays, UTF-8 strings. Anything else is refused by name rather than written differently.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np
from h5py import h5a, h5d, h5g, h5p, h5s, h5t
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument

__all__ = ["STRING", "attribute", "dataset", "empty_dataset", "group", "string_dataset"]

STRING = h5py.string_dtype("utf-8")
"""The stored type of every string: variable-length UTF-8, as h5py gives a ``str``."""

_CODEC_KEYS = frozenset({"chunks", "compression", "compression_opts", "shuffle"})

_group_plist: h5p.PropGCID | None = None
_dataset_plists: dict[tuple[Any, ...], Any] = {}
_types: dict[str, tuple[Any, Any]] = {}
_spaces: dict[tuple[int, ...], Any] = {}


def _group_creation() -> h5p.PropGCID:
    global _group_plist
    if _group_plist is None:
        plist = h5p.create(h5p.GROUP_CREATE)
        plist.set_obj_track_times(False)
        _group_plist = plist
    return _group_plist


def _dataset_creation(shape: tuple[int, ...], codec: Mapping[str, Any]) -> Any:
    """The creation property list ``Group.create_dataset(..., track_times=False, **codec)``
    builds (h5py's ``filters.fill_dcpl``, in its order), made once per distinct codec."""
    unknown = sorted(set(codec) - _CODEC_KEYS)
    if unknown:
        msg = (f"h5_objects.dataset takes the codecs of storage.layout ({sorted(_CODEC_KEYS)}), "
               f"got {unknown}; write other datasets with h5py's create_dataset")
        raise InvalidArgument(msg)
    compression = codec.get("compression")
    if compression not in (None, "gzip"):
        msg = (f"h5_objects.dataset compresses with 'gzip' (DEFLATE) or not at all, "
               f"got {compression!r}")
        raise InvalidArgument(msg)
    chunks = codec.get("chunks")
    key = (shape == (), None if chunks is None else tuple(chunks), bool(codec.get("shuffle")),
           None if compression is None else int(codec.get("compression_opts", 4)))
    plist = _dataset_plists.get(key)
    if plist is None:
        scalar, chunk_shape, shuffle, level = key
        if scalar and (chunk_shape is not None or shuffle or level is not None):
            msg = f"a scalar dataset takes no chunks or filters, got codec {dict(codec)}"
            raise InvalidArgument(msg)
        plist = h5p.create(h5p.DATASET_CREATE)
        if chunk_shape is not None:
            plist.set_chunk(chunk_shape)
        if shuffle:
            plist.set_shuffle()
        if level is not None:
            plist.set_deflate(level)
        plist.set_obj_track_times(False)
        _dataset_plists[key] = plist
    return plist


def _type(dtype: np.dtype[Any]) -> tuple[Any, Any]:
    """(the stored type, the in-memory type) of ``dtype``, as h5py makes them."""
    string = h5py.check_string_dtype(dtype)
    if string is not None and (string.encoding, string.length) != ("utf-8", None):
        msg = (f"h5_objects writes variable-length UTF-8 strings, got {string} ({dtype}); "
               "write it with h5py's create_dataset")
        raise InvalidArgument(msg)
    key = "string" if string is not None else dtype.str
    types = _types.get(key)
    if types is None:
        if string is None and dtype.kind not in "biuf":
            msg = (f"h5_objects writes numbers, booleans and UTF-8 strings, got dtype {dtype}; "
                   "convert the array or write it with h5py's create_dataset")
            raise InvalidArgument(msg)
        types = _types[key] = (h5t.py_create(dtype, logical=True), h5t.py_create(dtype))
    return types


def _space(shape: tuple[int, ...]) -> Any:
    space = _spaces.get(shape)
    if space is None:
        space = _spaces[shape] = h5s.create_simple(shape)
    return space


def group(parent: h5g.GroupID, name: str) -> h5g.GroupID:
    """A new group ``name`` in ``parent`` (a low-level id) without creation times."""
    return h5g.create(parent, name.encode("utf-8"), gcpl=_group_creation())


def empty_dataset(parent: h5g.GroupID, name: str, shape: tuple[int, ...], dtype: np.dtype[Any],
                  codec: Mapping[str, Any]) -> h5d.DatasetID:
    """A new dataset of ``shape`` and ``dtype`` stored with ``codec``, nothing written yet
    (its low-level id, e.g. for ``write_direct_chunk``)."""
    return h5d.create(parent, name.encode("utf-8"), _type(dtype)[0], _space(tuple(shape)),
                      dcpl=_dataset_creation(tuple(shape), codec))


def dataset(parent: h5g.GroupID, name: str, arr: NDArray[Any], codec: Mapping[str, Any]) -> None:
    """A new dataset ``name`` in ``parent`` holding ``arr``, stored with ``codec``."""
    data = np.asarray(arr, order="C")  # not ascontiguousarray: it makes a 0-d array 1-d
    ds = empty_dataset(parent, name, data.shape, data.dtype, codec)
    ds.write(h5s.ALL, h5s.ALL, data)


def string_dataset(parent: h5g.GroupID, name: str, text: str) -> None:
    """A new scalar dataset ``name`` holding ``text`` (variable-length UTF-8)."""
    dataset(parent, name, np.array(text, dtype=STRING), {})


def attribute(parent: h5g.GroupID | h5d.DatasetID, name: str,
              value: str | np.integer[Any] | np.bool_) -> None:
    """A new scalar attribute ``name`` of ``parent`` (a low-level id) holding ``value``."""
    data = np.array(value, dtype=STRING) if isinstance(value, str) else np.asarray(value)
    if data.shape != ():
        msg = f"h5_objects.attribute writes scalars, got {name!r} of shape {data.shape}"
        raise InvalidArgument(msg)
    stored, memory = _type(data.dtype)
    attr = h5a.create(parent, name.encode("utf-8"), stored, _space(()))
    try:
        attr.write(data, mtype=memory)
    finally:
        attr.close()
