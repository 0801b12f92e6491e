"""HDF5 shards: round trip, layout, inputs/targets separation, determinism, plain readers."""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from storage_factory import make_episode, make_mixed

import nsrmp_bench
from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.dsl.program import Node, Program
from nsrmp_bench.episode import (
    SCHEMA_VERSION,
    Episode,
    Instruction,
    ObjectTargets,
    Observations,
    Rendering,
    SymbolicEpisode,
)
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.storage import (
    episode_hash,
    open,
    read_manifest,
    root_hash,
    write_dataset,
    write_shard,
)


def _assert_same(a: Episode, b: Episode) -> None:
    assert a.symbolic == b.symbolic
    assert episode_hash(a) == episode_hash(b)
    if a.rendering is None:
        assert b.rendering is None
        return
    assert b.rendering is not None
    assert a.rendering.camera == b.rendering.camera
    assert a.rendering.physics == b.rendering.physics
    for name in ("poses", "boxes_amodal", "boxes_visible", "visible_fraction", "depth_centre"):
        np.testing.assert_array_equal(getattr(a.rendering.targets, name),
                                      getattr(b.rendering.targets, name))
    if a.rendering.observations is not None:
        ob = b.rendering.observations
        assert ob is not None
        for name in ("rgb", "depth", "segmentation"):
            x, y = getattr(a.rendering.observations, name), getattr(ob, name)
            assert x.dtype == y.dtype
            np.testing.assert_array_equal(x, y)
    if a.rendering.trajectory is not None:
        tb = b.rendering.trajectory
        assert tb is not None and tb.joint_names == a.rendering.trajectory.joint_names
        np.testing.assert_array_equal(a.rendering.trajectory.joint_positions, tb.joint_positions)


def _zero_step(index: int) -> Episode:
    """An episode whose program is just ``idle``: one state, no later images."""
    base = make_episode(index, steps=1)
    sym, r = base.symbolic, base.rendering
    assert r is not None and r.observations is not None
    zero = SymbolicEpisode(
        id=f"zero-{index}", generator=sym.generator, seed=sym.seed, scene=sym.scene,
        program=Program((Node("idle"),)), grounded=(), states=(sym.states[0],),
        instruction=Instruction("do nothing", "tpl-0", "simple"),
    )
    o, t = r.observations, r.targets
    obs = Observations(o.rgb[:1], o.depth[:1], o.segmentation[:1])
    targets = ObjectTargets(t.poses[:1], t.boxes_amodal[:1], t.boxes_visible[:1],
                            t.visible_fraction[:1], t.depth_centre[:1])
    return Episode(zero, Rendering(r.camera, obs, targets))


def test_round_trip_every_variant(tmp_path: Path) -> None:
    eps = [make_mixed(i) for i in range(10)]
    manifest = write_dataset(tmp_path, make_mixed, 0, 10, shard_size=4, split="test-v1",
                             versions={"pybullet": "3.2.7"})
    assert [s.file for s in manifest.shards] == [
        "shard-0000000-0000004.h5", "shard-0000004-0000008.h5", "shard-0000008-0000010.h5"]
    assert manifest.root_hash == root_hash((i, episode_hash(e)) for i, e in enumerate(eps))
    coll = nsrmp_bench.open(tmp_path, verify=True)
    assert len(coll) == 10
    for a, b in zip(eps, coll, strict=True):
        _assert_same(a, b)
    assert coll[-1].id == eps[-1].id
    assert [e.id for e in coll[2:5]] == [e.id for e in eps[2:5]]
    _assert_same(coll.get(eps[7].id), eps[7])
    with pytest.raises(UnknownId, match="no episode 'nope'"):
        coll.get("nope")
    with pytest.raises(IndexError):
        coll[10]


def test_zero_step_and_single_shard_open(tmp_path: Path) -> None:
    eps = [_zero_step(0), make_episode(1, trajectory=True)]
    record = write_shard(tmp_path, 0, eps, split="edge")
    coll = open(tmp_path / record.file)
    assert coll.split == "edge" and len(coll) == 2
    for a, b in zip(eps, coll, strict=True):
        _assert_same(a, b)


def test_iter_without_images_keeps_targets(tmp_path: Path) -> None:
    write_dataset(tmp_path, make_mixed, 0, 6, shard_size=6, split="test-v1")
    coll = open(tmp_path)
    for i, ep in enumerate(coll.iter_episodes()):
        want = make_mixed(i)
        assert ep.symbolic == want.symbolic
        if want.rendering is None:
            assert ep.rendering is None
            continue
        assert ep.rendering is not None and ep.rendering.observations is None
        np.testing.assert_array_equal(ep.rendering.targets.boxes_amodal,
                                      want.rendering.targets.boxes_amodal)


def test_index_dataframe(tmp_path: Path) -> None:
    write_dataset(tmp_path, make_mixed, 0, 7, shard_size=3, split="test-v1")
    for coll in (open(tmp_path), open(tmp_path / "shard-0000003-0000006.h5")):
        df = coll.index
        assert list(df.columns) == ["id", "split", "index", "steps", "objects", "relational",
                                    "relation_needed", "phrasing", "template", "shard"]
        for row in df.itertuples():
            cats = make_mixed(row.index).symbolic.categories()
            assert (row.steps, row.objects, row.relational, row.phrasing, row.template) == (
                cats["steps"], cats["objects"], cats["relational"], cats["phrasing"],
                cats["template"])
            assert row.split == "test-v1"
    assert list(open(tmp_path).index["index"]) == list(range(7))


def test_inputs_hold_no_gold(tmp_path: Path) -> None:
    ep = make_episode(3, steps=2)
    record = write_shard(tmp_path, 3, [ep], split="s")
    with h5py.File(tmp_path / record.file, "r") as f:
        g = f["data"][ep.id]
        names: list[str] = []
        g["inputs"].visit(names.append)
        assert sorted(names) == ["boxes_amodal", "boxes_visible", "instruction", "obs",
                                 "obs/depth", "obs/rgb"]
        assert g["inputs/obs/rgb"].shape == (24, 32, 3)
        assert g["inputs/boxes_amodal"].shape == (ep.symbolic.num_objects, 4)
        # the later states and the program live under targets only
        assert g["targets/obs/rgb"].shape == (2, 24, 32, 3)
        assert "program" in g["targets"] and "symbolic" in g["targets"]
    coll = open(tmp_path / record.file)
    inputs = coll.read_inputs(0)
    assert set(inputs) == {"id", "instruction", "rgb", "depth", "boxes", "boxes_visible",
                           "camera"}
    assert inputs["instruction"] == ep.symbolic.instruction.text
    assert ep.rendering is not None and inputs["camera"] == ep.rendering.camera


def test_plain_h5py_reads_every_array_with_builtin_filters(tmp_path: Path) -> None:
    write_dataset(tmp_path, make_mixed, 0, 4, shard_size=4, split="test-v1")
    path = tmp_path / "shard-0000000-0000004.h5"
    allowed = {h5py.h5z.FILTER_DEFLATE, h5py.h5z.FILTER_SHUFFLE}
    seen: list[str] = []

    def check(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            dcpl = obj.id.get_create_plist()
            ids = {dcpl.get_filter(k)[0] for k in range(dcpl.get_nfilters())}
            assert ids <= allowed, (name, ids)
            obj[()]
            seen.append(name)

    with h5py.File(path, "r") as f:
        f.visititems(check)
        assert f.attrs["schema_version"] == SCHEMA_VERSION
        for key in ("units", "vocabulary", "camera"):
            json.loads(f.attrs[key])
        rgb = f["data/test-v1-000000/targets/obs/rgb"]
        assert rgb.chunks == (1, 24, 32, 3) and rgb.compression == "gzip"
        assert f["data/test-v1-000000/inputs/obs/depth"].shuffle
    assert any(n.endswith("targets/robot/joint_positions") for n in seen)
    assert "mask/test-v1" in seen


@pytest.mark.skipif(shutil.which("h5dump") is None, reason="h5dump (hdf5-tools) not installed")
def test_h5dump_reads_images(tmp_path: Path) -> None:
    ep = make_episode(0)
    record = write_shard(tmp_path, 0, [ep], split="s")
    assert ep.rendering is not None and ep.rendering.observations is not None
    out = subprocess.run(
        ["h5dump", "-d", f"/data/{ep.id}/targets/obs/depth", str(tmp_path / record.file)],
        capture_output=True, text=True, check=True).stdout
    last_row = float(ep.rendering.observations.depth[1, -1, 0])
    assert f"{last_row:.1f}" in out and "DATA {" in out
    out = subprocess.run(["h5dump", "-d", f"/data/{ep.id}/targets/symbolic",
                          str(tmp_path / record.file)], capture_output=True, text=True,
                         check=True).stdout
    assert ep.id in out


def test_files_are_byte_deterministic_and_root_hash_ignores_sharding(tmp_path: Path) -> None:
    a = write_dataset(tmp_path / "a", make_mixed, 0, 6, shard_size=3, split="test-v1")
    time.sleep(1.1)  # any stored timestamp would now differ
    b = write_dataset(tmp_path / "b", make_mixed, 0, 6, shard_size=3, split="test-v1")
    c = write_dataset(tmp_path / "c", make_mixed, 0, 6, shard_size=5, split="test-v1")
    for s in a.shards:
        assert sha256_file(tmp_path / "a" / s.file) == sha256_file(tmp_path / "b" / s.file)
    assert (tmp_path / "a/manifest.json").read_bytes() == (tmp_path / "b/manifest.json"
                                                            ).read_bytes()
    assert a.root_hash == b.root_hash == c.root_hash
    assert [s.sha256 for s in a.shards] != [s.sha256 for s in c.shards]


def test_manifest_contents(tmp_path: Path) -> None:
    m = write_dataset(tmp_path, make_mixed, 0, 5, shard_size=2, split="test-v1",
                      versions={"pybullet": "3.2.7", "nsrmp-bench": "0.1.0"})
    data = json.loads((tmp_path / "manifest.json").read_text())
    assert data["split"] == "test-v1" and data["counts"]["episodes"] == 5
    assert data["counts"]["shards"] == 3 and data["index_range"] == [0, 5]
    assert data["versions"] == {"nsrmp-bench": "0.1.0", "pybullet": "3.2.7"}
    assert data["generator"] == "test-gen-v1"
    for s in data["shards"]:
        p = tmp_path / s["file"]
        assert s["bytes"] == p.stat().st_size
        assert s["sha256"] == hashlib.sha256(p.read_bytes()).hexdigest()
    assert [e["hash"] for e in data["episodes"]] == [episode_hash(make_mixed(i))
                                                     for i in range(5)]
    assert read_manifest(tmp_path) == m


def test_writer_rejects_bad_episodes(tmp_path: Path) -> None:
    ep = make_episode(0)
    assert ep.rendering is not None and ep.rendering.observations is not None
    from dataclasses import replace

    bad_obs = replace(ep.rendering.observations, rgb=ep.rendering.observations.rgb[:, :5])
    bad = Episode(ep.symbolic, replace(ep.rendering, observations=bad_obs))
    with pytest.raises(InvalidArgument, match=r"observations/rgb has shape .*expected"):
        write_shard(tmp_path, 0, [bad], split="s")
    assert not list(tmp_path.glob("*.h5*")), "an aborted shard leaves nothing behind"
    with pytest.raises(InvalidArgument, match="expects instance index 0 next"):
        write_shard(tmp_path, 0, [make_episode(1)], split="s")
    with pytest.raises(InvalidArgument, match=r"physics must be strict JSON .*NaN"):
        write_shard(tmp_path, 0, [Episode(ep.symbolic, replace(
            ep.rendering, physics={"drift": float("nan")}))], split="s")
    with pytest.raises(InvalidArgument, match="outside int16"):
        seg = ep.rendering.observations.segmentation.astype(np.int32) + 40000
        write_shard(tmp_path, 0, [Episode(ep.symbolic, replace(
            ep.rendering, observations=replace(ep.rendering.observations, segmentation=seg)))],
                    split="s")
