"""Generating a split part: instances -> physical, rendered episodes -> HDF5 shards.

Instance ``i`` of part ``p`` of split ``s`` is a pure function of (spec, p, i): attempt
``a`` samples the symbolic episode from ``SeedSequence(entropy_p, spawn_key=(i, a))`` and
realises it in PyBullet; a symbolic or physical rejection moves on to attempt ``a + 1``.
Shards are contiguous index ranges, one task each, handed to an engine (this process, a
local process pool or a Dask cluster: ``nsrmp_bench.engine``); each worker process keeps
one PyBullet world, reset for every instance, so the bytes do not depend on the engine,
the worker count or the order shards finish in. Complete shards are kept on a rerun
(resume after Ctrl-C, a kill or a lost scheduler).
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.metadata
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.dispatch import dispatch_versions
from nsrmp_bench.engine import Engine, TaskReport, open_engine
from nsrmp_bench.episode import Episode, SeedInfo
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.sampler import AttemptLog, first_valid, sample_symbolic
from nsrmp_bench.private_parts import bind_secret, commitment_record
from nsrmp_bench.split_specs import SplitSpec, load_split, resolve_split
from nsrmp_bench.storage.folder_lock import folder_lock
from nsrmp_bench.storage.layout import DATA_WRITER_VERSION
from nsrmp_bench.storage.manifest import Manifest
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.resume import scan_output, write_manifest
from nsrmp_bench.storage.writer import Background, shard_writer

if TYPE_CHECKING:
    from nsrmp_bench.generators.world.realise import Placer
    from nsrmp_bench.generators.world.world import World

__all__ = [
    "DEFAULT_SHARD_SIZE",
    "EXECUTORS",
    "generate_part",
    "generate_shard",
    "generate_split",
    "make_episode",
    "physics_fingerprint",
    "placer",
    "realise_config",
    "shard_writer_mode",
    "versions",
]

DEFAULT_SHARD_SIZE = 100
MAX_ATTEMPTS = 64
EXECUTORS = ("teleport", "robot")
"""What a split's ``executor`` can name: teleport-and-settle, or the Panda's pick-and-place."""


def placer(executor: str) -> Placer:
    """A fresh placer for ``executor`` (one of :data:`EXECUTORS`): what carries out each step
    when :func:`~nsrmp_bench.generators.world.realise.realise` realises an episode."""
    if executor == "teleport":
        from nsrmp_bench.generators.world.realise import TeleportPlacer

        return TeleportPlacer()
    if executor == "robot":
        from nsrmp_bench.generators.robot.realise import RobotPlacer

        return RobotPlacer()
    msg = (f"unknown executor {executor!r}; expected one of {list(EXECUTORS)} ('teleport': "
           "teleport and settle, 'robot': Panda pick-and-place): fix the split spec's executor")
    raise InvalidArgument(msg)


def realise_config(
    config: EpisodeConfig,
    entropy: int,
    index: int,
    episode_id: str,
    world: World,
    *,
    executor: str = "teleport",
    stats: AttemptLog | None = None,
) -> Episode:
    """The first attempt of instance ``index`` that samples and realises without rejection."""
    from nsrmp_bench.generators.world.realise import realise

    placer(executor)  # an unknown executor is refused before any sampling

    def attempt(seed: SeedInfo) -> Episode:
        symbolic = sample_symbolic(config, seed, episode_id)
        rendering = realise(symbolic.scene, symbolic.states, symbolic.grounded, world,
                            placer=placer(executor))
        return Episode(symbolic, rendering)

    return first_valid(entropy, index, attempt, max_attempts=MAX_ATTEMPTS, log=stats,
                       what=f" for {episode_id}")


def make_episode(
    spec: SplitSpec, part: str, index: int, world: World, stats: AttemptLog | None = None
) -> Episode:
    """Instance ``index`` of ``spec``'s ``part``, realised in ``world`` (a World).

    A private part's episode (its spec bound to the secret,
    :func:`~nsrmp_bench.private_parts.bind_secret`) stores a sealed seed: no entropy."""
    ps = spec.part(part)
    episode = realise_config(
        spec.config(part, index), ps.seed_entropy(spec.id), index,
        spec.episode_id(part, index), world, executor=spec.executor, stats=stats,
    )
    if not ps.private:
        return episode
    symbolic = dataclasses.replace(episode.symbolic, seed=episode.symbolic.seed.seal())
    return dataclasses.replace(episode, symbolic=symbolic)


# -- worker side (one task per shard range, whichever engine runs it) --------------------
_WORLDS: dict[tuple[int, int], Any] = {}


def _world(image: tuple[int, int]) -> Any:
    """This process's World for ``image`` (width, height): made once, reset per instance.
    The process keeps the memory its renders free for the next ones
    (:func:`~nsrmp_bench.generators.world.heap.retain_freed_memory`)."""
    if image not in _WORLDS:
        from nsrmp_bench.generators.world.heap import retain_freed_memory
        from nsrmp_bench.generators.world.world import World
        from nsrmp_bench.geometry.default_camera import official_camera

        retain_freed_memory()
        _WORLDS[image] = World(official_camera(*image))
    return _WORLDS[image]


def generate_shard(
    spec: SplitSpec, part: str, start: int, stop: int, out_dir: str,
    writer_mode: Background = True, *, report: TaskReport
) -> tuple[ShardRecord, AttemptLog]:
    """The task of one shard: instances ``[start, stop)`` of ``spec``'s ``part`` into ``out_dir``.

    The task carries the spec itself (not its id), so a custom spec file runs on any engine,
    remote workers included. The shard writer's ``*.tmp`` + rename makes it safe to run
    again after a worker died. ``writer_mode`` is the shard writer's ``background``
    (:func:`shard_writer_mode`).
    """
    world = _world(spec.image)
    stats = AttemptLog()
    with shard_writer(out_dir, start, stop, split=f"{spec.id}/{part}",
                     package_version=DATA_WRITER_VERSION, background=writer_mode) as writer:
        for i in range(start, stop):
            writer.add(make_episode(spec, part, i, world, stats))
            report.advance()
        record = writer.commit()
    return record, stats


# -- driver side ---------------------------------------------------------------------
def shard_writer_mode(engine: Engine) -> Background:
    """How the shards' tasks write: in a forked writer process where every generating
    process of the local machine leaves a core for its writer (PyBullet holds the GIL through
    its calls, so a writer thread mostly waits: measured, one worker wrote 42 episodes/s
    with a process and 32 with a thread), else on a thread (with every core generating,
    handing episodes to a process costs more than it frees: 45 against 48 episodes/s, two
    workers on two cores)."""
    here = engine.local_processes
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if here is not None and cores is not None and 2 * here <= cores:
        return "process"
    return True


def versions() -> dict[str, str]:
    """Package and simulator versions recorded in every manifest, with the CPU-dependent
    kernels in use (numpy's SIMD features, the BLAS core), which ``verify`` names when a
    robot episode differs in bits."""
    out = {"nsrmp-bench": DATA_WRITER_VERSION}
    for dist in ("pybullet", "numpy", "h5py"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = "not installed"
    out["physics_fingerprint"] = physics_fingerprint()
    out.update(dispatch_versions())
    return out


_FINGERPRINT: str | None = None


def physics_fingerprint() -> str:
    """Hash of one fixed two-step episode realised in a fresh world.

    Two machines whose PyBullet, numpy or CPU arithmetic differ in a way that changes
    generated data get different fingerprints; ``verify`` prints both when hashes differ.
    """
    global _FINGERPRINT
    if _FINGERPRINT is None:
        from nsrmp_bench.generators.world.world import World
        from nsrmp_bench.storage.hashing import episode_hash

        spec = load_split("smoke-v2")
        with World() as world:
            _FINGERPRINT = episode_hash(make_episode(spec, "test", 1, world))[:16]
    return _FINGERPRINT


ProgressCallback = Callable[[int], None]


def generate_part(
    spec: SplitSpec,
    part: str,
    out_dir: str | os.PathLike[str],
    *,
    workers: int = 2,
    engine: Engine | None = None,
    shard_size: int = DEFAULT_SHARD_SIZE,
    limit: int | None = None,
    on_progress: ProgressCallback | None = None,
    on_start: Callable[[int, int], None] | None = None,
    secret: str | None = None,
) -> tuple[Manifest, AttemptLog]:
    """Generate (or resume) one part into ``out_dir``; returns its manifest and stats.

    The shards still missing go to ``engine`` (entered by the caller), by default the local
    one with ``workers`` processes; the manifest is written here once all are complete.
    A private part needs its ``secret`` (:mod:`nsrmp_bench.private_parts`): it is never
    written; the manifest holds the commitment to it. One writer per folder: a second
    ``generate_part`` into ``out_dir`` while one runs is refused
    (:mod:`nsrmp_bench.storage.folder_lock`).
    """
    private = _private_record(spec, part, secret)
    spec = bind_secret(spec, secret)
    count = spec.part(part).count if limit is None else min(limit, spec.part(part).count)
    out = Path(out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "generate"):
        return _generate_locked(spec, part, out, count, private, workers=workers,
                                engine=engine, shard_size=shard_size,
                                on_progress=on_progress, on_start=on_start)


def _generate_locked(
    spec: SplitSpec, part: str, out: Path, count: int, private: dict[str, str] | None, *,
    workers: int, engine: Engine | None, shard_size: int,
    on_progress: ProgressCallback | None, on_start: Callable[[int, int], None] | None,
) -> tuple[Manifest, AttemptLog]:
    """:func:`generate_part`'s work, with the folder's lock held (one writer per part)."""
    (out / "manifest.json").unlink(missing_ok=True)
    if private is not None:
        _same_commitment(out, private)
    state = scan_output(out)
    todo = state.missing(0, count, shard_size)
    done = count - sum(b - a for a, b in todo)
    if on_start is not None:
        on_start(count, done)
    stats = AttemptLog()
    if todo:
        with contextlib.ExitStack() as stack:
            if engine is None:
                engine = stack.enter_context(open_engine("local", workers=workers))
            engine.require_shared_dir(out)
            mode = shard_writer_mode(engine)
            tasks = [(spec, part, a, b, str(out), mode) for a, b in todo]
            for _, (_, log) in engine.map_unordered(generate_shard, tasks,
                                                    on_progress=on_progress):
                stats.merge(log)
    manifest = write_manifest(
        out, split=f"{spec.id}/{part}", versions=versions(), index_range=(0, count),
        generator=spec.generator, verify=False,
        spec=None if spec.shipped else spec.to_dict(), private=private,
    )
    return manifest, stats


PRIVATE_STATE = "private.json"
"""The commitment a private part's directory is being generated under (kept for resume)."""


def _private_record(spec: SplitSpec, part: str, secret: str | None) -> dict[str, str] | None:
    """The manifest's commitment for a private part (None for a public one); a private
    part without its secret is an error before any work."""
    ps = spec.part(part)
    if not ps.private:
        return None
    if secret is None:
        raise ps.missing_secret(spec.id)
    return commitment_record(spec, part, secret)


def _same_commitment(out: Path, private: dict[str, str]) -> None:
    """Refuse to resume a private part's shards made with another secret."""
    state = out / PRIVATE_STATE
    if state.is_file():
        before = json.loads(state.read_text("utf-8"))
        if before != private:
            msg = (f"{out} holds shards generated with another secret (commitment "
                   f"{str(before.get('commitment'))[:16]}..., this secret gives "
                   f"{private['commitment'][:16]}...); give the same secret to resume, or "
                   "generate into an empty directory")
            raise InvalidArgument(msg)
    elif any(out.glob("shard-*")):
        msg = (f"{out} holds shards but no {PRIVATE_STATE}: they were not made for this "
               "private part; generate into an empty directory")
        raise InvalidArgument(msg)
    else:
        state.write_text(json.dumps(private, sort_keys=True) + "\n", "utf-8")


def generate_split(
    split: str | SplitSpec,
    out_dir: str | os.PathLike[str],
    *,
    parts: list[str] | None = None,
    **kwargs: Any,
) -> dict[str, tuple[Manifest, AttemptLog]]:
    """Generate every part (or ``parts``) of ``split`` (an id, a spec file path, or a
    :class:`SplitSpec`) into ``out_dir/<part>/``."""
    spec = split if isinstance(split, SplitSpec) else resolve_split(split)
    names = list(spec.parts) if parts is None else parts
    return {p: generate_part(spec, p, Path(out_dir) / p, **kwargs) for p in names}


