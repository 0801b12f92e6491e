"""A perturbed copy of a part: the same episodes, ids and gold, other instruction texts.

``perturb_part(src, out, kind=..., seed=...)`` writes ``out`` as an ordinary part (HDF5
shards over the source's index ranges, ``manifest.json``) that ``score``, ``compare``,
``predict``, the boards and ``evaluate`` take unchanged, plus ``perturbations.jsonl``:
one line per instance in index order (id, whether the kind changed it, the original and
the new text, what changed or why nothing did). The manifest's ``perturbation`` section
records the kind, the seed, the source part's root hash, the lexicon's version and the
records' sha256. Instance *i*'s text is a pure function of (kind, seed, the source
instance): the same seed gives the same bytes. Every file is written under a temporary
name and renamed when complete; the manifest comes last, so a stopped run leaves no part
that looks complete.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.robustness.kinds import KINDS, Perturbed, lexicon, perturb_instruction
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.manifest import MANIFEST_NAME, Manifest, build_manifest, read_manifest
from nsrmp_bench.storage.reader import open as open_part
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.writer import shard_writer

__all__ = ["RECORDS_NAME", "PerturbReport", "instance_rng", "perturb_part", "read_records",
           "shuffled_sources"]

RECORDS_NAME = "perturbations.jsonl"
"""The per-instance records of a perturbed part, beside its manifest."""


def instance_rng(kind: str, seed: int, index: int) -> np.random.Generator:
    """The generator of instance ``index`` under ``kind`` and ``seed`` (a pure function)."""
    code = zlib.crc32(kind.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence([seed, code, index]))


def shuffled_sources(count: int, seed: int) -> list[int]:
    """For each position, another position whose instruction it takes (a random cyclic
    permutation, so no position keeps its own; Sattolo's algorithm under ``seed``)."""
    order = list(range(count))
    rng = np.random.default_rng(np.random.SeedSequence([seed, zlib.crc32(b"shuffled")]))
    for i in range(count - 1, 0, -1):
        j = int(rng.integers(0, i))
        order[i], order[j] = order[j], order[i]
    return order


@dataclass(frozen=True)
class PerturbReport:
    """What :func:`perturb_part` wrote."""

    out: Path
    kind: str
    seed: int
    count: int
    changed: int
    manifest: Manifest

    @property
    def unchanged(self) -> int:
        """Instances the kind could not change (each record says why)."""
        return self.count - self.changed


def _check(src: Path, out: Path, kind: str, seed: int) -> Manifest:
    if kind not in KINDS:
        msg = f"--kind {kind!r}; expected one of {', '.join(KINDS)}"
        raise InvalidArgument(msg)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        msg = f"--seed {seed!r}; expected a non-negative integer"
        raise InvalidArgument(msg)
    manifest = read_manifest(src)
    if manifest.perturbation is not None:
        msg = (f"{src} is already a perturbed part ({manifest.perturbation.get('kind')}); "
               "perturb the unperturbed part instead, so that every kind is measured "
               "against the same instructions")
        raise InvalidArgument(msg)
    if out.resolve() == src.resolve():
        msg = f"--out {out} is the source part; give another folder"
        raise InvalidArgument(msg)
    if (out / MANIFEST_NAME).exists():
        msg = (f"{out} already holds a part ({MANIFEST_NAME}); remove it or give another "
               "--out")
        raise InvalidArgument(msg)
    return manifest


def _with_text(episode: Episode, result: Perturbed) -> Episode:
    if not result.changed:
        return episode
    sym = episode.symbolic
    instruction = dataclasses.replace(sym.instruction, text=result.text, lexed="")
    return dataclasses.replace(episode, symbolic=dataclasses.replace(sym,
                                                                     instruction=instruction))


def perturb_part(
    src: str | os.PathLike[str], out: str | os.PathLike[str], *, kind: str, seed: int,
    words: str = "test", progress: Callable[[int], None] | None = None,
) -> PerturbReport:
    """Write the ``kind`` perturbation of part ``src`` (under ``seed``, with the word lists
    ``words``: ``test``, the suite's, or ``dev``) into ``out``.

    ``progress`` is called with the number of episodes written after each one.
    """
    src_p, out_p = Path(src), Path(out)
    manifest = _check(src_p, out_p, kind, seed)
    lex = lexicon(words)
    out_p.mkdir(parents=True, exist_ok=True)
    records: list[str] = []
    shard_records: list[ShardRecord] = []
    changed = 0
    with open_part(src_p) as part:
        texts: list[str] = []
        if kind == "shuffled":
            texts = [part.episode(i, images=False).symbolic.instruction.text
                     for i in range(len(part))]
            sources = shuffled_sources(len(part), seed)
        ids = part.ids
        done = 0
        for shard in manifest.shards:
            with shard_writer(out_p, shard.start, shard.stop, split=manifest.split,
                             background=False) as writer:
                for entry in shard.episodes:
                    pos = part.position(entry.id)
                    episode = part.episode(pos, images=True)
                    instr = episode.symbolic.instruction
                    rng = instance_rng(kind, seed, entry.index)
                    other = texts[sources[pos]] if kind == "shuffled" else None
                    result = perturb_instruction(kind, instr.text, rng, lexed=instr.lexed,
                                                 other=other, words=words)
                    writer.add(_with_text(episode, result))
                    changed += result.changed
                    row: dict[str, Any] = {"index": entry.index, "id": entry.id,
                                           "original": instr.text, **result.to_dict()}
                    if other is not None:
                        row["source"] = ids[sources[pos]]
                    records.append(canonical_json(row))
                    done += 1
                    if progress is not None:
                        progress(done)
                shard_records.append(writer.commit())
    body = "\n".join(records) + "\n"
    atomic_write_text(out_p / RECORDS_NAME, body)
    perturbation = {
        "kind": kind,
        "seed": int(seed),
        "lexicon": str(lex["version"]),
        "source_split": manifest.split,
        "source_root_hash": manifest.root_hash,
        "records": RECORDS_NAME,
        "records_sha256": hashlib.sha256(body.encode("utf-8")).hexdigest(),
        "changed": changed,
        "unchanged": len(records) - changed,
    }
    new = dataclasses.replace(
        build_manifest(shard_records, split=manifest.split, generator=manifest.generator,
                       versions=manifest.versions, spec=manifest.spec),
        perturbation=perturbation,
    )
    new.write(out_p)
    return PerturbReport(out_p, kind, int(seed), len(records), changed, new)


def read_records(part: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The per-instance records of a perturbed part, in index order."""
    path = Path(part) / RECORDS_NAME
    try:
        lines = path.read_text("utf-8").splitlines()
    except FileNotFoundError as exc:
        msg = (f"no {RECORDS_NAME} in {part}: it is not a perturbed part; make one with "
               "`nsrmp-bench perturb`")
        raise InvalidArgument(msg) from exc
    return [json.loads(line) for line in lines if line]
