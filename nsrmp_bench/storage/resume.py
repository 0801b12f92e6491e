"""Resuming generation: which shards of an output directory are complete, which are not.

Run :func:`scan_output` only while no writer works in the directory (the generation runner
calls it before it starts its workers): it removes every ``*.tmp``.

A shard is *complete* when its file has its final name, a ``.record.json`` sits next to it,
and the file's size and sha256 match the record. A final-named shard without a record (a
writer killed between the rename and the record) is checked episode by episode and gets
its record rebuilt; a shard whose bytes disagree with its record is removed.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import DataIntegrityError, InvalidArgument
from nsrmp_bench.storage.layout import (
    DATA_WRITER_VERSION,
    FORMAT,
    RECORD_SUFFIX,
    SHARD_SUFFIX,
    TMP_SUFFIX,
    check_schema_version,
    parse_shard_filename,
)
from nsrmp_bench.storage.manifest import MANIFEST_NAME, Manifest, build_manifest
from nsrmp_bench.storage.reader import read_episode
from nsrmp_bench.storage.records import CATEGORY_KEYS, EpisodeEntry, ShardRecord
from nsrmp_bench.storage.tolerance import TOLERANT_EXECUTORS, tolerant_summary
from nsrmp_bench.storage.writer import shard_writer

__all__ = [
    "OutputState",
    "record_from_shard",
    "scan_output",
    "shard_ranges",
    "write_dataset",
    "write_manifest",
]


def shard_ranges(start: int, stop: int, shard_size: int) -> list[tuple[int, int]]:
    """Split ``[start, stop)`` into shards aligned on multiples of ``shard_size``.

    Alignment on absolute multiples means machines that generate disjoint index ranges
    with the same shard size produce the same shard files.
    """
    if shard_size <= 0 or start < 0 or stop < start:
        msg = (
            f"need shard_size > 0 and 0 <= start <= stop; got shard_size={shard_size}, "
            f"start={start}, stop={stop}"
        )
        raise InvalidArgument(msg)
    out = []
    a = start
    while a < stop:
        b = min(stop, (a // shard_size + 1) * shard_size)
        out.append((a, b))
        a = b
    return out


def record_from_shard(path: str | os.PathLike[str], split: str | None = None) -> ShardRecord:
    """Rebuild a shard's record from the file itself (checks format, version and count)."""
    p = Path(path)
    rng = parse_shard_filename(p.name)
    if rng is None:
        msg = f"{p.name} is not a shard file name (shard-AAAAAAA-BBBBBBB.h5)"
        raise InvalidArgument(msg)
    try:
        with h5py.File(p, "r") as f:
            if f.attrs.get("format") != FORMAT:
                msg = f"{p}: format attribute is {f.attrs.get('format')!r}, not {FORMAT!r}"
                raise DataIntegrityError(msg)
            check_schema_version(f.attrs.get("schema_version"), str(p))
            rows = json.loads(f["index"].asstr()[()])
            entries = []
            for row in rows:
                g = f["data"][row["id"]]
                cats = {k: row[k] for k in CATEGORY_KEYS if k in row}
                tolerant = (tolerant_summary(read_episode(g, images=False))
                            if g.attrs.get("executor") in TOLERANT_EXECUTORS else None)
                entries.append(EpisodeEntry(int(row["index"]), str(row["id"]),
                                            str(g.attrs["content_hash"]), cats, tolerant))
            file_split = str(f.attrs.get("split", ""))
            generator = str(f.attrs.get("generator", ""))
    except (OSError, KeyError, ValueError) as exc:
        msg = f"shard {p} is truncated or corrupt ({exc}); delete it and generate it again"
        raise DataIntegrityError(msg) from exc
    if [e.index for e in entries] != list(range(*rng)):
        msg = f"shard {p} does not hold exactly the indices [{rng[0]}, {rng[1]}); regenerate it"
        raise DataIntegrityError(msg)
    if split is not None and file_split != split:
        msg = f"shard {p} belongs to split {file_split!r}, not {split!r}"
        raise InvalidArgument(msg)
    return ShardRecord(p.name, rng[0], rng[1], sha256_file(p), p.stat().st_size, file_split,
                       tuple(entries), generator)


@dataclass(frozen=True)
class OutputState:
    """What :func:`scan_output` found in an output directory."""

    out_dir: Path
    complete: tuple[ShardRecord, ...]
    removed: tuple[str, ...]
    recovered: tuple[str, ...]

    def missing(self, start: int, stop: int, shard_size: int) -> list[tuple[int, int]]:
        """The shard ranges of ``[start, stop)`` still to generate (none partly done)."""
        done = {(r.start, r.stop) for r in self.complete}
        out = []
        for a, b in shard_ranges(start, stop, shard_size):
            if (a, b) in done:
                continue
            clash = [r.file for r in self.complete if r.start < b and a < r.stop]
            if clash:
                msg = (
                    f"shard range [{a}, {b}) overlaps complete shards {clash} of another "
                    f"shard size; resume with the shard size used before, or remove them"
                )
                raise InvalidArgument(msg)
            out.append((a, b))
        return out


def scan_output(out_dir: str | os.PathLike[str], *, verify: bool = True) -> OutputState:
    """Find the complete shards of ``out_dir``; remove ``*.tmp`` and shards that fail.

    With ``verify`` (the default) every complete shard's sha256 is recomputed; without it
    only sizes are compared.
    """
    d = Path(out_dir)
    if not d.exists():
        return OutputState(d, (), (), ())
    removed: list[str] = []
    recovered: list[str] = []
    complete: list[ShardRecord] = []
    for tmp in sorted(d.glob("*" + TMP_SUFFIX)):
        tmp.unlink()
        removed.append(tmp.name)
    for shard in sorted(d.glob("shard-*" + SHARD_SUFFIX)):
        if parse_shard_filename(shard.name) is None:
            continue
        rec_path = d / (shard.name + RECORD_SUFFIX)
        record: ShardRecord | None = None
        if rec_path.exists():
            try:
                record = ShardRecord.read(rec_path)
            except DataIntegrityError:
                record = None
        if record is None:
            try:
                record = record_from_shard(shard)
            except DataIntegrityError:
                shard.unlink()
                rec_path.unlink(missing_ok=True)
                removed.append(shard.name)
                continue
            record.write(d)
            recovered.append(shard.name)
        ok = shard.stat().st_size == record.bytes and (
            not verify or sha256_file(shard) == record.sha256
        )
        if not ok:
            shard.unlink()
            rec_path.unlink()
            removed.append(shard.name)
            continue
        complete.append(record)
    for rec_path in sorted(d.glob("shard-*" + SHARD_SUFFIX + RECORD_SUFFIX)):
        if not (d / rec_path.name[: -len(RECORD_SUFFIX)]).exists():
            rec_path.unlink()
            removed.append(rec_path.name)
    return OutputState(d, tuple(complete), tuple(removed), tuple(recovered))


def write_manifest(
    out_dir: str | os.PathLike[str],
    *,
    split: str,
    versions: Mapping[str, str] | None = None,
    index_range: tuple[int, int] | None = None,
    generator: str | None = None,
    verify: bool = True,
    spec: Mapping[str, Any] | None = None,
    private: Mapping[str, str] | None = None,
) -> Manifest:
    """Build ``manifest.json`` from the complete shards of ``out_dir`` and write it.

    ``versions`` (package, simulator, ...) come from the caller. With ``index_range`` the
    shards must cover exactly that range. ``spec`` is the spec of an unofficial split,
    written into the manifest (None for a shipped split); ``private`` a private part's
    commitment.
    """
    state = scan_output(out_dir, verify=verify)
    if not state.complete:
        msg = f"no complete shard in {out_dir}; generate the shards first"
        raise InvalidArgument(msg)
    manifest = build_manifest(state.complete, split=split, versions=versions,
                              generator=generator, spec=spec, private=private)
    if index_range is not None and manifest.index_range != tuple(index_range):
        msg = (
            f"the shards of {out_dir} cover indices {list(manifest.index_range)}, expected "
            f"{list(index_range)}; generate the missing shards first"
        )
        raise InvalidArgument(msg)
    manifest.write(out_dir)
    return manifest


def write_dataset(
    out_dir: str | os.PathLike[str],
    make_episode: Callable[[int], Episode],
    start: int,
    stop: int,
    *,
    shard_size: int,
    split: str,
    versions: Mapping[str, str] | None = None,
    package_version: str = DATA_WRITER_VERSION,
    on_shard: Callable[[ShardRecord], None] | None = None,
) -> Manifest:
    """Write instances ``[start, stop)`` into shards, resuming, then the manifest.

    ``make_episode(i)`` gives instance ``i``. Shards already complete are skipped, so a run
    killed at any point and started again reaches the same files and manifest. This is the
    sequential driver; a parallel runner hands :func:`shard_ranges` out to workers, each
    writing with :func:`~nsrmp_bench.storage.writer.shard_writer`, then calls
    :func:`write_manifest`.
    """
    out = Path(out_dir)
    (out / MANIFEST_NAME).unlink(missing_ok=True)
    state = scan_output(out)
    for a, b in state.missing(start, stop, shard_size):
        with shard_writer(out, a, b, split=split, package_version=package_version) as w:
            for i in range(a, b):
                w.add(make_episode(i))
            record = w.commit()
        if on_shard is not None:
            on_shard(record)
    return write_manifest(out, split=split, versions=versions, index_range=(start, stop),
                          verify=False)
