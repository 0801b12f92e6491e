"""Inputs-only parts: a part's shards with the gold cut out, for a test whose gold is held by
a scoring server (``nsrmp-bench pack --inputs-only``).

Each episode keeps what a model may read (the README's data dictionary rows outside
:data:`GOLD_FIELDS`): its id, index, object count, generator, flags, camera, executor and
the whole ``inputs/`` group. It loses ``targets/`` (later states, boxes, poses, program,
symbolic episode), the physics report, the step count and the seed (which with a public
entropy regenerates the gold). The shard's ``/index`` keeps ids and indices only, and its
root says ``inputs_only``.

``@content_hash`` stays: a one-way hash of the whole episode, it reveals nothing of the
gold, and it lets the pack's manifest keep the gold part's episode hashes and **root
hash**: predictions made on the pack name the same manifest as the part they are scored
on. The pack's manifest says ``"inputs_only": true``; its rows keep index, id, hash and the
object count; its shards' sha256 are the new files'.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import h5_objects
from nsrmp_bench.storage.atomic import atomic_path
from nsrmp_bench.storage.layout import LIBVER, create_group
from nsrmp_bench.storage.manifest import Manifest, read_manifest
from nsrmp_bench.storage.records import EpisodeEntry, ShardRecord

__all__ = ["GOLD_ATTRIBUTES", "GOLD_FIELDS", "INPUT_CATEGORIES", "is_gold", "strip_part"]

GOLD_ATTRIBUTES = ("num_steps", "seed")
"""Episode attributes an inputs-only part drops: the program's length, and the seed."""
GOLD_FIELDS = ("targets", "physics")
"""Episode members an inputs-only part drops: the gold group and the physics report."""
INPUT_CATEGORIES = ("objects",)
"""The manifest categories an inputs-only part keeps (the object count is in the inputs)."""


def is_gold(field: str) -> bool:
    """Whether a data-dictionary field (``@name``, ``group/name``) is gold, that is, dropped
    from an inputs-only part."""
    if field.startswith("@"):
        return field[1:] in GOLD_ATTRIBUTES
    return field.split("/", 1)[0] in GOLD_FIELDS


def _strip_shard(src: Path, dest: Path) -> None:
    """Write ``dest``: the shard ``src`` without its gold."""
    with h5py.File(src, "r") as f, atomic_path(dest) as tmp, \
            h5py.File(tmp, "w", libver=LIBVER) as out:
        for key, value in f.attrs.items():
            out.attrs[key] = value
        out.attrs["inputs_only"] = True
        data = create_group(out, "data")
        for key, value in f["data"].attrs.items():
            data.attrs[key] = value
        for eid in f["data"]:
            g = f["data"][eid]
            eg = create_group(data, eid)
            for key, value in g.attrs.items():
                if key not in GOLD_ATTRIBUTES:
                    eg.attrs[key] = value
            for name in g:
                if name not in GOLD_FIELDS:
                    f.copy(g[name], eg, name)
        f.copy(f["mask"], out, "mask")
        rows = json.loads(f["index"].asstr()[()])
        kept = [{k: r[k] for k in ("id", "index", *INPUT_CATEGORIES) if k in r} for r in rows]
        text = json.dumps(kept, sort_keys=True, separators=(",", ":"), allow_nan=False)
        h5_objects.string_dataset(out.id, "index", text)


def _entry(e: EpisodeEntry) -> EpisodeEntry:
    cats = {k: v for k, v in e.categories.items() if k in INPUT_CATEGORIES}
    return EpisodeEntry(e.index, e.id, e.hash, cats, None)


def strip_part(part_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str]) -> Manifest:
    """Write the inputs-only copy of the part ``part_dir`` into ``out_dir`` (its shards and
    ``manifest.json``); returns the new manifest (same episodes and root hash)."""
    src = Path(part_dir)
    manifest = read_manifest(src)
    if manifest.inputs_only:
        msg = f"{src} is already an inputs-only part; pack the full part it was cut from"
        raise InvalidArgument(msg)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    shards: list[ShardRecord] = []
    for s in manifest.shards:
        _strip_shard(src / s.file, out / s.file)
        shards.append(ShardRecord(
            file=s.file, start=s.start, stop=s.stop, sha256=sha256_file(out / s.file),
            bytes=(out / s.file).stat().st_size, split=s.split,
            episodes=tuple(_entry(e) for e in s.episodes), generator=s.generator,
        ))
    stripped = Manifest(
        split=manifest.split, generator=manifest.generator,
        schema_version=manifest.schema_version, versions=dict(manifest.versions),
        shards=tuple(shards), root_hash=manifest.root_hash, spec=manifest.spec,
        private=manifest.private, inputs_only=True,
    )
    stripped.write(out)
    return stripped
