"""Verifying generated or downloaded data against its manifest and the committed one.

:func:`verify` recomputes every shard's sha256 and every episode's content hash, compares
them with the data's own ``manifest.json``, then compares the root hash with the manifest
committed in ``splits/manifests/``. When hashes differ it names the shard and episodes and
explains the likely cause from the recorded versions (PyBullet, numpy, physics fingerprint)
and CPU-dependent kernels (numpy's SIMD features, the BLAS core). Teleport episodes must be
the same bytes on every machine; robot episodes, which are not bit-stable across CPUs, are
accepted when they agree within the tolerances their committed manifest states
(``storage/tolerance.py``). Shards are checked one task each by an engine (this process, a
local pool or a Dask cluster; ``nsrmp_bench.engine``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.dispatch import DISPATCH_KEYS
from nsrmp_bench.engine import Engine, InlineEngine, TaskReport, in_task_order
from nsrmp_bench.errors import DataIntegrityError, NSRMPError
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.plurals import counted
from nsrmp_bench.private_parts import commitment_problem
from nsrmp_bench.split_specs import SplitSpec, load_split, withdrawal
from nsrmp_bench.storage.hashing import episode_hash, root_hash
from nsrmp_bench.storage.manifest import Manifest, read_manifest
from nsrmp_bench.storage.reader import read_episode
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.tolerance import compare_summaries, tolerant_summary

__all__ = ["Comparison", "ShardCheck", "VerifyReport", "check_shard", "compare_with_committed",
           "identical_files", "verify"]

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
    within_tolerance: bool = False
    identical_files: int | None = None
    """Shard files whose sha256 and size equal the committed manifest's shard of the same
    name (None without a committed manifest)."""
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every hash matched."""
        return not self.problems


def _withdrawn_note(split_id: str) -> str:
    """`` (split X was withdrawn: why; use Y)`` for a withdrawn split, else ``""``."""
    gone = withdrawal(split_id)
    return "" if gone is None else f" (split {split_id!r} was withdrawn; use {gone['use']!r})"


def _explain(local: dict[str, Any], committed: dict[str, Any], *, files_ok: bool) -> list[str]:
    """The likely causes of a difference from the committed manifest, most specific first."""
    lines: list[str] = []
    kernels: list[str] = []
    for key in sorted(set(local) | set(committed)):
        a, b = local.get(key, "not recorded"), committed.get(key, "not recorded")
        if a == b:
            continue
        line = f"{key}: {a} here, {b} in the committed manifest"
        (kernels if key in DISPATCH_KEYS else lines).append(line)
    if lines:
        return lines + kernels
    if not files_ok:
        return ["the recorded versions agree, and the files do not match their own "
                "manifest: they were changed or damaged after generation; regenerate or "
                "re-download them"]
    cause = ("the files match their own manifest (they are as generated) and the recorded "
             "versions agree, so generation itself computed differently on this CPU")
    report = ("; teleport episodes must not depend on that: please report it as a bug, with "
              "the output of `python -c \"import numpy; numpy.show_runtime()\"`")
    here = ", ".join(f"{k} {local.get(k, 'not recorded')}" for k in DISPATCH_KEYS)
    if all(k not in committed for k in DISPATCH_KEYS):
        return [f"{cause}: its CPU-dependent kernels are {here}, which the committed manifest "
                f"does not record{report}"]
    if kernels:
        return [f"{cause}: its CPU-dependent kernels differ ({'; '.join(kernels)}){report}"]
    return [f"{cause}, although the recorded CPU-dependent kernels agree ({here}): a "
            f"library below numpy (libm, PyBullet) picked another code path, or simulator "
            f"state carried over from one instance to the next (how the withdrawn v1 "
            f"splits differed){report}"]


@dataclass(frozen=True)
class Comparison:
    """How local episode hashes compare with a committed manifest's."""

    exact: bool
    differ: list[int]
    within_tolerance: list[int]
    beyond_tolerance: dict[int, list[str]]
    missing: list[int]

    @property
    def ok(self) -> bool:
        """Every episode equal, or (robot episodes) equal within tolerances."""
        return not self.differ_beyond and not self.missing

    @property
    def differ_beyond(self) -> list[int]:
        """Indices that differ and are not excused by a tolerant comparison."""
        return [i for i in self.differ if i not in set(self.within_tolerance)]


def compare_with_committed(
    local: dict[int, tuple[str, dict[str, Any] | None]], committed: dict[str, Any]
) -> Comparison:
    """Compare ``{index: (hash, tolerant summary)}`` with a committed manifest (a dict).

    An episode whose hash differs is accepted when both sides carry a tolerant summary
    (robot episodes) and the summaries agree within the stated tolerances.
    """
    theirs = {int(e["index"]): e for e in committed["episodes"]}
    differ = [i for i, (h, _) in sorted(local.items())
              if i not in theirs or theirs[i]["hash"] != h]
    within: list[int] = []
    beyond: dict[int, list[str]] = {}
    for i in differ:
        ref = theirs.get(i, {}).get("tolerant")
        if ref is None:
            continue
        problems = compare_summaries(local[i][1], ref)
        if problems:
            beyond[i] = problems
        else:
            within.append(i)
    missing = sorted(set(theirs) - set(local))
    return Comparison(not differ and not missing, differ, within, beyond, missing)


@dataclass(frozen=True)
class ShardCheck:
    """What checking one shard found: its episodes' hashes and summaries, and problems."""

    hashes: dict[int, str]
    summaries: dict[int, dict[str, Any] | None]
    episodes: int
    problems: list[str]


def check_shard(part_dir: str, shard: ShardRecord, deep: bool, *,
                report: TaskReport | None = None) -> ShardCheck:
    """The task of one shard: its sha256, and with ``deep`` every episode's content hash."""
    path = Path(part_dir) / shard.file
    if not path.is_file():
        return ShardCheck({}, {}, 0, [f"{shard.file}: missing; regenerate or re-download it"])
    problems: list[str] = []
    if sha256_file(path) != shard.sha256:
        problems.append(
            f"{shard.file}: sha256 differs from manifest.json (file changed or truncated)"
        )
    if not deep:
        return ShardCheck({e.index: e.hash for e in shard.episodes},
                          {e.index: e.tolerant for e in shard.episodes}, 0, problems)
    hashes: dict[int, str] = {}
    summaries: dict[int, dict[str, Any] | None] = {}
    try:
        with h5py.File(path, "r") as f:
            group = f["data"]
            for entry in shard.episodes:
                episode = read_episode(group[entry.id])
                h = episode_hash(episode)
                hashes[entry.index] = h
                summaries[entry.index] = tolerant_summary(episode)
                if report is not None:
                    report.advance()
                if h != entry.hash:
                    problems.append(
                        f"{shard.file}: episode {entry.id} content differs from its "
                        "manifest hash"
                    )
    except (OSError, KeyError, NSRMPError) as exc:
        problems.append(f"{shard.file}: unreadable ({exc}); regenerate or re-download")
    return ShardCheck(hashes, summaries, len(hashes), problems)


def identical_files(manifest: Manifest, committed: dict[str, Any]) -> int:
    """How many of ``manifest``'s shard files have the sha256 and size of the committed
    manifest's shard of the same name."""
    theirs = {str(s["file"]): (str(s["sha256"]), int(s["bytes"]))
              for s in committed.get("shards", [])}
    return sum(1 for s in manifest.shards if theirs.get(s.file) == (s.sha256, s.bytes))


def _files_note(same: int, here: int, committed: int) -> str:
    """Whether the files, not only the episodes, are the committed ones."""
    if same == here == committed:
        return f"every shard file is byte for byte the committed one ({counted(same, 'shard')})"
    return (f"{same} of {counted(here, 'shard file')} here are byte for byte the committed "
            f"ones ({committed} committed): the episodes are the same, the files are not "
            "(another --shard-size, another nsrmp-bench version, which each file records, or "
            "another h5py/HDF5 laying the files out)")


def _spec_problem(manifest: Manifest, spec: SplitSpec) -> str | None:
    """Why the data was not generated from ``spec``, or None."""
    split_id = manifest.split.partition("/")[0]
    if split_id != spec.id:
        return f"the data is split {split_id!r}, not {spec.id!r} of {spec.source or spec.id}"
    if spec.shipped == manifest.official and (spec.shipped or manifest.spec == spec.to_dict()):
        return None
    return (f"the spec the data was generated from (in its manifest) differs from "
            f"{spec.source or spec.id}; regenerate with that spec, or verify against the "
            "spec it was made from")


def verify(
    data_dir: str | os.PathLike[str], *, deep: bool = True, spec: SplitSpec | None = None,
    engine: Engine | None = None, secret: str | None = None,
) -> VerifyReport:
    """Check ``data_dir`` (a part directory with ``manifest.json``).

    A private part's manifest holds a commitment to its secret; with ``secret`` (the
    revealed one) the commitment is opened, and a wrong secret is a problem.

    Data of an unofficial split (generated from a spec file) is checked against its own
    manifest only; with ``spec`` the manifest's spec must also be that one. The shards are
    checked by ``engine`` (entered by the caller; default: this process), one task each;
    the report is the same whichever engine checks them.
    """
    d = Path(data_dir).resolve()
    manifest = read_manifest(d)
    report = VerifyReport(Path(data_dir), manifest.split)
    wrong_spec = _spec_problem(manifest, spec) if spec is not None else None
    if wrong_spec is not None:
        report.problems.append(wrong_spec)
    if manifest.inputs_only:  # its episode hashes cover gold it does not hold
        deep = False
        report.notes.append(
            "inputs-only part (packed without its gold): its shards' sha256 are checked and "
            "its episode hashes and root hash compared with the full part's; verify the "
            "full part to rehash the episodes")
    recomputed: dict[int, str] = {}
    summaries: dict[int, dict[str, Any] | None] = {}
    engine = InlineEngine() if engine is None else engine
    engine.require_shared_dir(d)
    tasks = [(str(d), shard, deep) for shard in manifest.shards]
    for check in in_task_order(engine.map_unordered(check_shard, tasks)):
        report.shards += 1
        report.episodes += check.episodes
        report.problems.extend(check.problems)
        recomputed.update(check.hashes)
        summaries.update(check.summaries)
    report.root_hash = root_hash(recomputed.items())
    if report.root_hash != manifest.root_hash and not report.problems:
        report.problems.append("root hash differs from manifest.json although episodes match")
    _check_commitment(report, manifest, secret)
    if manifest.perturbation is not None:
        pert = manifest.perturbation
        report.notes.append(
            f"a perturbed copy ({pert.get('kind')}, seed {pert.get('seed')}) of a part whose "
            f"root hash is {pert.get('source_root_hash')}: checked against its own manifest; "
            "`nsrmp-bench perturb SOURCE --kind KIND --seed SEED` makes the same bytes")
        return report
    if not manifest.official:
        report.notes.append(f"unofficial split {manifest.split} (made from a spec file; the "
                            "spec is in its manifest): no committed manifest to compare")
        return report
    split_id, _, part = manifest.split.partition("/")
    committed = official_manifest(split_id, part) if part else None
    if committed is None:
        report.notes.append(f"no committed manifest for {manifest.split}: checked locally only"
                            + _withdrawn_note(split_id))
        return report
    report.committed_root_hash = str(committed["root_hash"])
    report.identical_files = identical_files(manifest, committed)
    if report.committed_root_hash == report.root_hash:
        if not report.problems and not manifest.inputs_only:
            report.notes.append(_files_note(report.identical_files, len(manifest.shards),
                                            len(committed.get("shards", []))))
        return report
    files_ok = not report.problems
    cmp = compare_with_committed(
        {i: (h, summaries.get(i)) for i, h in recomputed.items()}, committed
    )
    if cmp.within_tolerance:
        report.notes.append(
            f"{len(cmp.within_tolerance)} robot episodes differ in bits from the committed "
            "manifest but agree within its stated tolerances (robot episodes are not "
            "bit-stable across CPUs; see the manifest's \"comparison\")"
        )
    if cmp.ok:
        report.within_tolerance = True
        return report
    bad = cmp.differ_beyond
    if bad:
        ids = [f"{manifest.split}/{i:06d}" for i in bad[:_SHOW]]
        report.problems.append(
            f"root hash {report.root_hash[:16]} differs from the committed "
            f"{report.committed_root_hash[:16]}: {len(bad)} episodes differ "
            f"(first: {', '.join(ids)})"
        )
        for i, why in list(cmp.beyond_tolerance.items())[:_SHOW]:
            report.problems.append(f"{manifest.split}/{i:06d} beyond tolerance: "
                                   + "; ".join(why))
        report.problems.extend(
            "likely cause: " + line
            for line in _explain(manifest.versions, committed.get("versions", {}),
                                 files_ok=files_ok)
        )
    if cmp.missing:
        fix = ("the data is incomplete; generate the whole part (no --limit) or finish "
               "the download" if files_ok else
               "they are in the damaged shards named above: delete those shards and rerun "
               "the same `generate` (it makes only what is missing) or download them again")
        report.problems.append(
            f"{len(cmp.missing)} of the committed manifest's episodes are absent here "
            f"(indices {cmp.missing[0]}..{cmp.missing[-1]}): {fix}"
        )
    return report


def _check_commitment(report: VerifyReport, manifest: Manifest, secret: str | None) -> None:
    """A private part's commitment, opened with the revealed ``secret`` when given."""
    split_id, _, part = manifest.split.partition("/")
    if manifest.private is None:
        if secret is not None:  # e.g. $NSRMP_BENCH_SECRET set for other parts: harmless
            report.notes.append(
                f"a secret was given, but {manifest.split} is not a private part (its "
                "manifest holds no commitment): the secret was not used")
        return
    if secret is None:
        report.notes.append(
            f"private part: its entropy is a secret, committed to by "
            f"{manifest.private.get('commitment', '')[:16]}...; once the secret is revealed, "
            "`nsrmp-bench verify DATA --secret-file SECRET` opens the commitment")
        return
    spec = manifest.spec if manifest.spec is not None else load_split(split_id).to_dict()
    problem = commitment_problem(manifest.private, spec, part, secret)
    if problem is not None:
        report.problems.append(problem)
    else:
        report.notes.append("the revealed secret opens the manifest's commitment: this part "
                            "was generated from it (regenerate with it to compare the data)")


def require_ok(report: VerifyReport) -> None:
    """Raise DataIntegrityError listing the problems unless the report is clean."""
    if not report.ok:
        msg = f"{report.data_dir} failed verification: " + "; ".join(report.problems)
        raise DataIntegrityError(msg)
