"""Verifying generated or downloaded data against its manifest and the committed one.

:func:`verify` recomputes every shard's sha256 and every episode's content hash, compares
them with the data's own ``manifest.json``, then compares the root hash with the manifest
committed in ``splits/manifests/``. When hashes differ it names the shard and episodes and
explains the likely cause from the recorded versions (PyBullet, numpy, physics fingerprint).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.errors import DataIntegrityError, NSRMPError
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.storage.hashing import episode_hash, root_hash
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.reader import read_episode

__all__ = ["VerifyReport", "verify"]

_SHOW = 10


@dataclass
class VerifyReport:
    """What :func:`verify` checked and what differed."""

    data_dir: Path
    split: str
    shards: int = 0
    episodes: int = 0
    root_hash: str = ""
    committed_root_hash: str | None = None
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every hash matched."""
        return not self.problems


def _explain(local: dict[str, Any], committed: dict[str, Any]) -> list[str]:
    lines = []
    for key in sorted(set(local) | set(committed)):
        a, b = local.get(key, "absent"), committed.get(key, "absent")
        if a != b:
            lines.append(f"{key}: {a} here, {b} in the committed manifest")
    if not lines:
        lines.append("the recorded versions agree; the files were changed after generation")
    return lines


def verify(data_dir: str | os.PathLike[str], *, deep: bool = True) -> VerifyReport:
    """Check ``data_dir`` (a part directory with ``manifest.json``)."""
    d = Path(data_dir)
    manifest = read_manifest(d)
    report = VerifyReport(d, manifest.split)
    recomputed: dict[int, str] = {}
    for shard in manifest.shards:
        path = d / shard.file
        report.shards += 1
        if not path.is_file():
            report.problems.append(f"{shard.file}: missing; regenerate or re-download it")
            continue
        if sha256_file(path) != shard.sha256:
            report.problems.append(
                f"{shard.file}: sha256 differs from manifest.json (file changed or truncated)"
            )
        if not deep:
            recomputed.update((e.index, e.hash) for e in shard.episodes)
            continue
        try:
            with h5py.File(path, "r") as f:
                group = f["data"]
                for entry in shard.episodes:
                    h = episode_hash(read_episode(group[entry.id]))
                    recomputed[entry.index] = h
                    report.episodes += 1
                    if h != entry.hash:
                        report.problems.append(
                            f"{shard.file}: episode {entry.id} content differs from its "
                            "manifest hash"
                        )
        except (OSError, KeyError, NSRMPError) as exc:
            report.problems.append(f"{shard.file}: unreadable ({exc}); regenerate or re-download")
    report.root_hash = root_hash(recomputed.items())
    if report.root_hash != manifest.root_hash and not report.problems:
        report.problems.append("root hash differs from manifest.json although episodes match")
    split_id, _, part = manifest.split.partition("/")
    committed = official_manifest(split_id, part) if part else None
    if committed is None:
        report.notes.append(f"no committed manifest for {manifest.split}: checked locally only")
        return report
    report.committed_root_hash = str(committed["root_hash"])
    if report.committed_root_hash != report.root_hash:
        theirs = {int(e["index"]): e["hash"] for e in committed["episodes"]}
        differ = [i for i, h in sorted(recomputed.items()) if theirs.get(i) != h]
        missing = sorted(set(theirs) - set(recomputed))
        ids = [f"{manifest.split}/{i:06d}" for i in differ[:_SHOW]]
        report.problems.append(
            f"root hash {report.root_hash[:16]} differs from the committed "
            f"{report.committed_root_hash[:16]}: {len(differ)} episodes differ"
            + (f" (first: {', '.join(ids)})" if ids else "")
            + (f", {len(missing)} committed episodes absent" if missing else "")
        )
        report.problems.extend(
            "likely cause: " + line
            for line in _explain(manifest.versions, committed.get("versions", {}))
        )
    return report


def require_ok(report: VerifyReport) -> None:
    """Raise DataIntegrityError listing the problems unless the report is clean."""
    if not report.ok:
        msg = f"{report.data_dir} failed verification: " + "; ".join(report.problems)
        raise DataIntegrityError(msg)
