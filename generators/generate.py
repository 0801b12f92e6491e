"""Generating a split part: instances -> physical, rendered episodes -> HDF5 shards.

Instance ``i`` of part ``p`` of split ``s`` is a pure function of (spec, p, i): attempt
``a`` samples the symbolic episode from ``SeedSequence(entropy_p, spawn_key=(i, a))`` and
realises it in PyBullet; a symbolic or physical rejection moves on to attempt ``a + 1``.
Shards are contiguous index ranges handed to a process pool, one PyBullet world per worker
process, so the bytes do not depend on the worker count or the order shards finish in.
Complete shards are kept on a rerun (resume after Ctrl-C or a kill).
"""

from __future__ import annotations

import importlib.metadata
import multiprocessing as mp
import os
import queue as queue_module
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

from nsrmp_bench import __version__
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.dispatch import dispatch_versions
from nsrmp_bench.episode import Episode, SeedInfo
from nsrmp_bench.generators.sampler import AttemptLog, first_valid, sample_symbolic
from nsrmp_bench.split_specs import SplitSpec, load_split, resolve_split
from nsrmp_bench.storage.manifest import Manifest
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.resume import scan_output, write_manifest
from nsrmp_bench.storage.writer import ShardWriter

__all__ = [
    "DEFAULT_SHARD_SIZE",
    "generate_part",
    "generate_split",
    "make_episode",
    "physics_fingerprint",
    "realise_config",
    "versions",
]

DEFAULT_SHARD_SIZE = 100
MAX_ATTEMPTS = 64


def realise_config(
    config: EpisodeConfig,
    entropy: int,
    index: int,
    episode_id: str,
    world: Any,
    *,
    executor: str = "teleport",
    stats: AttemptLog | None = None,
) -> Episode:
    """The first attempt of instance ``index`` that samples and realises without rejection."""
    from nsrmp_bench.generators.world.realise import realise

    def attempt(seed: SeedInfo) -> Episode:
        symbolic = sample_symbolic(config, seed, episode_id)
        rendering = realise(symbolic.scene, symbolic.states, symbolic.grounded, world,
                            executor=executor)
        return Episode(symbolic, rendering)

    return first_valid(entropy, index, attempt, max_attempts=MAX_ATTEMPTS, log=stats,
                       what=f" for {episode_id}")


def make_episode(
    spec: SplitSpec, part: str, index: int, world: Any, stats: AttemptLog | None = None
) -> Episode:
    """Instance ``index`` of ``spec``'s ``part``, realised in ``world`` (a World)."""
    return realise_config(
        spec.config(part, index), spec.part(part).entropy, index,
        spec.episode_id(part, index), world, executor=spec.executor, stats=stats,
    )


# -- worker side ---------------------------------------------------------------------
_WORLD: Any = None
_QUEUE: Any = None


def _init_worker(spec: SplitSpec, progress: Any) -> None:
    global _WORLD, _QUEUE
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.geometry.default_camera import official_camera

    _WORLD = World(official_camera(*spec.image))
    _QUEUE = progress


def _generate_shard(
    spec: SplitSpec, part: str, start: int, stop: int, out_dir: str
) -> tuple[ShardRecord, AttemptLog]:
    stats = AttemptLog()
    with ShardWriter(out_dir, start, stop, split=f"{spec.id}/{part}",
                     package_version=__version__) as writer:
        for i in range(start, stop):
            writer.add(make_episode(spec, part, i, _WORLD, stats))
            if _QUEUE is not None:
                _QUEUE.put(1)
        record = writer.commit()
    return record, stats


# -- driver side ---------------------------------------------------------------------
def versions() -> dict[str, str]:
    """Package and simulator versions recorded in every manifest, with the CPU-dependent
    kernels in use (numpy's SIMD features, the BLAS core), which ``verify`` names when a
    robot episode differs in bits."""
    out = {"nsrmp-bench": __version__}
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
    shard_size: int = DEFAULT_SHARD_SIZE,
    limit: int | None = None,
    on_progress: ProgressCallback | None = None,
    on_start: Callable[[int, int], None] | None = None,
) -> tuple[Manifest, AttemptLog]:
    """Generate (or resume) one part into ``out_dir``; returns its manifest and stats."""
    count = spec.part(part).count if limit is None else min(limit, spec.part(part).count)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "manifest.json").unlink(missing_ok=True)
    state = scan_output(out)
    todo = state.missing(0, count, shard_size)
    done = count - sum(b - a for a, b in todo)
    if on_start is not None:
        on_start(count, done)
    stats = AttemptLog()
    if todo:
        ctx = mp.get_context("spawn")
        with ctx.Manager() as manager:
            progress = manager.Queue()
            with ProcessPoolExecutor(
                max_workers=max(1, min(workers, len(todo))), mp_context=ctx,
                initializer=_init_worker, initargs=(spec, progress),
            ) as pool:
                pending: set[Future[tuple[ShardRecord, AttemptLog]]] = {
                    pool.submit(_generate_shard, spec, part, a, b, str(out)) for a, b in todo
                }
                try:
                    while pending:
                        finished, pending = wait(pending, timeout=0.2,
                                                 return_when=FIRST_COMPLETED)
                        _drain(progress, on_progress)
                        for fut in finished:
                            stats.merge(fut.result()[1])
                    _drain(progress, on_progress)
                except BaseException:
                    for fut in pending:
                        fut.cancel()
                    raise
    manifest = write_manifest(
        out, split=f"{spec.id}/{part}", versions=versions(), index_range=(0, count),
        generator=spec.generator, verify=False,
        spec=None if spec.shipped else spec.to_dict(),
    )
    return manifest, stats


def _drain(progress: Any, on_progress: ProgressCallback | None) -> None:
    n = 0
    while True:
        try:
            n += progress.get_nowait()
        except queue_module.Empty:
            break
    if n and on_progress is not None:
        on_progress(n)


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


