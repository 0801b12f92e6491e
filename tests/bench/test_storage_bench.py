"""Storage benchmarks: shard write/read, DataLoader vs raw h5py, MCAP export.

Two ways to run it:

* ``pytest tests/bench/test_storage_bench.py -o addopts="" --benchmark-only`` (tables;
  ``NSRMP_BENCH_EPISODES`` sets the number of episodes, default 64);
* ``python tests/bench/test_storage_bench.py --episodes 200 [--codecs]`` prints every
  figure of one run (per-episode write/read times, bytes per episode, DataLoader
  episodes/s at 0 and 2 workers next to raw h5py reads of the same data, MCAP export rate
  and size; ``--codecs`` adds the codec comparison on the same images).

The episodes are real ones (paper-v2 train, rendered with PyBullet) when the generators
and PyBullet are importable, else synthetic ones from the storage test factory.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "storage"))

from nsrmp_bench.episode import Episode
from nsrmp_bench.storage import open as open_data
from nsrmp_bench.storage import write_dataset

DEFAULT_EPISODES = int(os.environ.get("NSRMP_BENCH_EPISODES", "64"))


def make_episodes(n: int) -> tuple[list[Episode], str]:
    """``n`` episodes and a word on where they came from."""
    try:
        from nsrmp_bench.generators.generate import make_episode
        from nsrmp_bench.generators.world.world import World
        from nsrmp_bench.geometry.default_camera import official_camera
        from nsrmp_bench.split_specs import load_split

        spec = load_split("paper-v2")
        with World(official_camera(*spec.image)) as world:
            return [make_episode(spec, "train", i, world) for i in range(n)], "paper-v2/train"
    except ImportError:
        from storage_factory import make_episode as synthetic

        return [synthetic(i, width=320, height=240) for i in range(n)], "synthetic"


def write(episodes: list[Episode], out: Path, shard_size: int = 1000) -> Path:
    """Write ``episodes`` (instance indices 0..n-1) as a data directory."""
    write_dataset(out, lambda i: episodes[i], 0, len(episodes), shard_size=shard_size,
                  split="bench")
    return out


def read_all(data: Path, images: bool = True) -> int:
    """Read every episode through the collection."""
    n = 0
    with open_data(data) as coll:
        for ep in coll.iter_episodes(images=images):
            n += ep.symbolic.num_objects > 0
    return n


def raw_h5py_read(data: Path) -> int:
    """The same per-item reads as the Dataset, with plain h5py (no nsrmp-bench code)."""
    n = 0
    for shard in sorted(data.glob("shard-*.h5")):
        with h5py.File(shard, "r") as f:
            for name, g in f["data"].items():
                g["inputs/obs/rgb"][()]
                g["inputs/obs/depth"][()]
                g["inputs/boxes_amodal"][()]
                g["inputs/instruction"][()]
                json.loads(g["targets/symbolic"][()])
                g["targets/boxes_amodal"][()]
                g["targets/poses"][()]
                g["targets/program"][()]
                n += bool(name)
    return n


def dataloader_epoch(data: Path, workers: int) -> tuple[float, int]:
    """Seconds for one epoch (after a warm-up epoch) with persistent workers."""
    from nsrmp_bench.dataset import EpisodeDataset, data_loader

    loader = data_loader(EpisodeDataset(data), batch_size=16, num_workers=workers,
                         shuffle=True)
    for _ in loader:  # warm-up: starts the workers, opens files, fills the page cache
        pass
    t = time.perf_counter()
    n = sum(len(b["id"]) for b in loader)
    return time.perf_counter() - t, n


def best_of(fn: Callable[[], Any], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def codec_table(episodes: list[Episode], out: Path) -> list[tuple[str, float, float, float]]:
    """(codec, KB/episode, write ms/episode, read ms/episode) for the episodes' images."""
    variants: dict[str, Callable[[np.ndarray], dict[str, Any]]] = {
        "gzip1 (+shuffle f32) [chosen]": lambda a: {"compression": "gzip",
                                                    "compression_opts": 1,
                                                    "shuffle": a.dtype.kind == "f"},
        "gzip4 (+shuffle f32) [storage-formats.md]": lambda a: {
            "compression": "gzip", "compression_opts": 4, "shuffle": a.dtype.kind == "f"},
        "gzip6 (+shuffle f32)": lambda a: {"compression": "gzip", "compression_opts": 6,
                                           "shuffle": a.dtype.kind == "f"},
        "lzf (+shuffle f32; h5py-only filter)": lambda a: {"compression": "lzf",
                                                           "shuffle": a.dtype.kind == "f"},
        "none": lambda a: {},
    }
    rows: list[tuple[str, float, float, float]] = []
    readers: list[Callable[[], None]] = []
    for name, kw in variants.items():
        path = out / f"codec-{len(rows)}.h5"
        t = time.perf_counter()
        with h5py.File(path, "w", libver=("v110", "v110")) as f:
            for e in episodes:
                assert e.rendering is not None and e.rendering.observations is not None
                o = e.rendering.observations
                g = f.create_group(e.id)
                for key, arr in (("rgb", o.rgb), ("depth", o.depth), ("seg", o.segmentation)):
                    opts = kw(arr)
                    chunks = (1, *arr.shape[1:]) if opts else None
                    g.create_dataset(key, data=arr, chunks=chunks, **opts)
        wt = (time.perf_counter() - t) / len(episodes)

        def read(p: Path = path) -> None:
            with h5py.File(p, "r") as f:
                for g in f.values():
                    for key in ("rgb", "depth", "seg"):
                        g[key][()]

        readers.append(read)
        rows.append((name, path.stat().st_size / len(episodes) / 1024, wt * 1e3, 0.0))
    # read in alternating order, best of 7 rounds: timings on a busy machine are noisy
    best = [float("inf")] * len(rows)
    for r in range(7):
        order = range(len(rows)) if r % 2 == 0 else reversed(range(len(rows)))
        for k in order:
            best[k] = min(best[k], best_of(readers[k], 1))
    return [(name, kb, wms, best[k] / len(episodes) * 1e3)
            for k, (name, kb, wms, _) in enumerate(rows)]


def measure(n: int, codecs: bool = False) -> dict[str, Any]:
    """Every figure of the storage benchmark, from one set of episodes."""
    episodes, source = make_episodes(n)
    out: dict[str, Any] = {"episodes": n, "source": source}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        t = time.perf_counter()
        data = write(episodes, root / "data")
        out["write_ms_per_episode"] = (time.perf_counter() - t) / n * 1e3
        size = sum(p.stat().st_size for p in data.glob("shard-*.h5"))
        out["bytes_per_episode"] = size / n
        out["raw_bytes_per_episode"] = sum(
            sum(a.nbytes for a in (e.rendering.observations.rgb, e.rendering.observations.depth,
                                   e.rendering.observations.segmentation))
            for e in episodes if e.rendering is not None and e.rendering.observations
        ) / n
        out["read_ms_per_episode"] = best_of(lambda: read_all(data)) / n * 1e3
        out["read_no_images_ms_per_episode"] = best_of(
            lambda: read_all(data, images=False)) / n * 1e3
        raw = best_of(lambda: raw_h5py_read(data))
        out["raw_h5py_episodes_per_s"] = n / raw
        for workers in (0, 2):
            try:
                secs, m = dataloader_epoch(data, workers)
                out[f"dataloader_w{workers}_episodes_per_s"] = m / secs
            except ImportError:
                out[f"dataloader_w{workers}_episodes_per_s"] = None
        try:
            from nsrmp_bench.storage.mcap_export import export_mcap

            summary = export_mcap(data, root / "out.mcap")
            out["mcap_episodes_per_s"] = n / summary.seconds
            out["mcap_bytes_per_episode"] = summary.bytes / n
            out["mcap_messages"] = summary.messages
        except ImportError:
            out["mcap_episodes_per_s"] = None
        if codecs:
            out["codecs"] = codec_table(episodes, root)
    return out


# -- pytest-benchmark -----------------------------------------------------------------
@pytest.fixture(scope="module")
def bench_data(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Episode], Path]:
    episodes, _ = make_episodes(DEFAULT_EPISODES)
    return episodes, write(episodes, tmp_path_factory.mktemp("bench") / "data")


def test_bench_write(benchmark: Any, bench_data: tuple[list[Episode], Path],
                     tmp_path: Path) -> None:
    episodes, _ = bench_data
    counter = iter(range(1000))
    data = benchmark.pedantic(lambda: write(episodes, tmp_path / f"w{next(counter)}"),
                              rounds=3, iterations=1)
    size = sum(p.stat().st_size for p in data.glob("shard-*.h5"))
    benchmark.extra_info["episodes"] = len(episodes)
    benchmark.extra_info["bytes_per_episode"] = size / len(episodes)


def test_bench_read_episodes(benchmark: Any, bench_data: tuple[list[Episode], Path]) -> None:
    episodes, data = bench_data
    assert benchmark(read_all, data) == len(episodes)
    benchmark.extra_info["episodes"] = len(episodes)


def test_bench_read_without_images(benchmark: Any, bench_data: tuple[list[Episode], Path]
                                   ) -> None:
    episodes, data = bench_data
    assert benchmark(read_all, data, False) == len(episodes)


def test_bench_raw_h5py(benchmark: Any, bench_data: tuple[list[Episode], Path]) -> None:
    episodes, data = bench_data
    assert benchmark(raw_h5py_read, data) == len(episodes)


@pytest.mark.parametrize("workers", [0, 2])
def test_bench_dataloader(benchmark: Any, bench_data: tuple[list[Episode], Path],
                          workers: int) -> None:
    pytest.importorskip("torch")
    from nsrmp_bench.dataset import EpisodeDataset, data_loader

    episodes, data = bench_data
    loader = data_loader(EpisodeDataset(data), batch_size=16, num_workers=workers,
                         shuffle=True)
    for _ in loader:
        pass
    n = benchmark.pedantic(lambda: sum(len(b["id"]) for b in loader), rounds=3, iterations=1)
    assert n == len(episodes)


def test_bench_mcap_export(benchmark: Any, bench_data: tuple[list[Episode], Path],
                           tmp_path: Path) -> None:
    pytest.importorskip("mcap_protobuf")
    from nsrmp_bench.storage.mcap_export import export_mcap

    episodes, data = bench_data
    summary = benchmark.pedantic(lambda: export_mcap(data, tmp_path / "b.mcap"), rounds=2,
                                 iterations=1)
    benchmark.extra_info["mcap_bytes_per_episode"] = summary.bytes / len(episodes)


def main() -> None:
    """Print the figures of one run."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=DEFAULT_EPISODES)
    parser.add_argument("--codecs", action="store_true", help="add the codec comparison")
    args = parser.parse_args()
    r = measure(args.episodes, codecs=args.codecs)
    print(f"episodes: {r['episodes']} ({r['source']}), {os.cpu_count()} CPU cores")
    print(f"write: {r['write_ms_per_episode']:.1f} ms/episode (incl. hashing, fsync, record)")
    print(f"size: {r['bytes_per_episode'] / 1024:.1f} KB/episode "
          f"(raw images {r['raw_bytes_per_episode'] / 1024:.1f} KB/episode)")
    print(f"read with images: {r['read_ms_per_episode']:.2f} ms/episode; without images: "
          f"{r['read_no_images_ms_per_episode']:.2f} ms/episode")
    print(f"raw h5py (same datasets as the Dataset): {r['raw_h5py_episodes_per_s']:.0f} "
          "episodes/s")
    for w in (0, 2):
        v = r[f"dataloader_w{w}_episodes_per_s"]
        print(f"DataLoader num_workers={w}: " + (f"{v:.0f} episodes/s" if v else "no torch"))
    if r["mcap_episodes_per_s"]:
        print(f"MCAP export: {r['mcap_episodes_per_s']:.1f} episodes/s, "
              f"{r['mcap_bytes_per_episode'] / 1024:.1f} KB/episode, "
              f"{r['mcap_messages']} messages")
    for name, kb, wms, rms in r.get("codecs", []):
        print(f"codec {name:42s} {kb:7.1f} KB/episode  write {wms:5.2f} ms  read {rms:5.2f} ms")


if __name__ == "__main__":
    main()
