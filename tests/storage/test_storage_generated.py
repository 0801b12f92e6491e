"""Real generated episodes (sampler + PyBullet world) through shards, the reader and MCAP."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("pybullet")
pytestmark = pytest.mark.sim

generate = pytest.importorskip("nsrmp_bench.generators.generate")
world_mod = pytest.importorskip("nsrmp_bench.generators.world.world")
split_specs = pytest.importorskip("nsrmp_bench.split_specs")

from nsrmp_bench.episode import Episode  # noqa: E402
from nsrmp_bench.geometry.default_camera import official_camera  # noqa: E402
from nsrmp_bench.storage import episode_hash, open, write_dataset  # noqa: E402

N = 4


@pytest.fixture(scope="module")
def generated() -> list[Episode]:
    spec = split_specs.load_split("smoke-v2")
    with world_mod.World(official_camera(*spec.image)) as world:
        return [generate.make_episode(spec, "test", i, world) for i in range(N)]


def test_generated_episodes_round_trip(generated: list[Episode], tmp_path: Path) -> None:
    eps = {e.symbolic.seed.index: e for e in generated}
    manifest = write_dataset(tmp_path, lambda i: eps[i], 0, N, shard_size=3,
                             split="smoke-v2/test")
    coll = open(tmp_path, verify=True)
    assert coll.ids == [e.id for e in generated]
    for want, got in zip(generated, coll, strict=True):
        assert got.symbolic == want.symbolic
        assert episode_hash(got) == episode_hash(want)
        assert want.rendering is not None and got.rendering is not None
        assert want.rendering.observations is not None
        assert got.rendering.observations is not None
        np.testing.assert_array_equal(got.rendering.observations.rgb,
                                      want.rendering.observations.rgb)
        np.testing.assert_array_equal(got.rendering.observations.depth,
                                      want.rendering.observations.depth)
        assert got.rendering.physics == want.rendering.physics
    assert [e.hash for e in manifest.episodes] == [episode_hash(e) for e in generated]
    with h5py.File(tmp_path / manifest.shards[0].file, "r") as f:
        assert list(f["mask/smoke-v2/test"].asstr()[()]) == [e.id for e in generated[:3]]


def test_generated_episodes_export_to_mcap(generated: list[Episode], tmp_path: Path) -> None:
    pytest.importorskip("mcap_protobuf")
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    from nsrmp_bench.storage.mcap_export import export_mcap

    eps = {e.symbolic.seed.index: e for e in generated}
    write_dataset(tmp_path / "d", lambda i: eps[i], 0, N, shard_size=N, split="smoke-v2/test")
    summary = export_mcap(tmp_path / "d", tmp_path / "g.mcap")
    with (tmp_path / "g.mcap").open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        n = sum(1 for _ in reader.iter_decoded_messages(topics=["/camera/rgb", "/camera/depth"]))
    assert n == 2 * sum(e.symbolic.num_steps + 1 for e in generated)
    assert summary.messages > n
