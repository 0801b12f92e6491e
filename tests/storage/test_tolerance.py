"""Robot episodes: tolerant summaries in records and manifests; verify's likely causes."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from storage_factory import make_episode

from nsrmp_bench.episode import Episode
from nsrmp_bench.storage import write_dataset
from nsrmp_bench.storage.resume import scan_output
from nsrmp_bench.storage.tolerance import ROBOT_TOLERANCES, compare_summaries, tolerant_summary
from nsrmp_bench.verify import _explain, compare_with_committed


def _robot(index: int, shift_m: float = 0.0) -> Episode:
    ep = make_episode(index, trajectory=True)
    r = ep.rendering
    assert r is not None and r.trajectory is not None
    poses = r.targets.poses.copy()
    poses[..., :3] += shift_m
    targets = dataclasses.replace(r.targets, poses=poses)
    traj = dataclasses.replace(r.trajectory, ee_pose=r.trajectory.ee_pose + shift_m)
    return Episode(ep.symbolic, dataclasses.replace(r, executor="robot", targets=targets,
                                                    trajectory=traj))


def test_only_robot_episodes_get_a_summary() -> None:
    assert tolerant_summary(make_episode(0)) is None
    assert tolerant_summary(make_episode(0, trajectory=True)) is None  # executor "panda"
    s = tolerant_summary(_robot(0))
    assert s is not None and s["symbolic"] and s["samples"] == 12
    json.dumps(s)  # plain JSON


def test_last_bit_differences_pass_and_real_ones_are_named() -> None:
    ref = tolerant_summary(_robot(1))
    assert compare_summaries(tolerant_summary(_robot(1, 1e-12)), ref) == []
    assert compare_summaries(tolerant_summary(_robot(1, 1e-3)), ref) == []
    far = compare_summaries(tolerant_summary(_robot(1, 6e-3)), ref)
    assert any("mm" in line and "pose" in line for line in far)
    assert any("end-effector" in line for line in far)
    other = compare_summaries(tolerant_summary(_robot(2)), ref)
    assert other and "symbolic" in other[0]
    assert ROBOT_TOLERANCES["position_mm"] == 3.0


def test_manifest_states_the_comparison_and_recovery_keeps_summaries(tmp_path: Path) -> None:
    write_dataset(tmp_path, _robot, 0, 3, shard_size=3, split="robot-test-v1")
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["comparison"]["tolerant"]["tolerances"] == ROBOT_TOLERANCES
    assert all("tolerant" in e for e in manifest["episodes"])
    record = next(tmp_path.glob("*.record.json"))
    before = json.loads(record.read_text())
    record.unlink()  # a shard without its record: rebuilt from the file
    state = scan_output(tmp_path)
    assert [e.tolerant for e in state.complete[0].episodes] == \
        [e["tolerant"] for e in before["episodes"]]
    moved = {i: ("other-hash", tolerant_summary(_robot(i, 1e-9))) for i in range(3)}
    cmp = compare_with_committed(moved, manifest)
    assert cmp.ok and cmp.within_tolerance == [0, 1, 2]
    far = {i: ("other-hash", tolerant_summary(_robot(i, 8e-3))) for i in range(3)}
    assert compare_with_committed(far, manifest).differ_beyond == [0, 1, 2]


def test_teleport_episodes_stay_exact(tmp_path: Path) -> None:
    write_dataset(tmp_path, make_episode, 0, 2, shard_size=2, split="t-v1")
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert "comparison" not in manifest
    cmp = compare_with_committed({0: ("x", None), 1: (manifest["episodes"][1]["hash"], None)},
                                 manifest)
    assert not cmp.ok and cmp.differ_beyond == [0]


def test_likely_cause_names_the_kernels_not_the_files() -> None:
    same = {"numpy": "2.4.6", "pybullet": "3.2.7"}
    [line] = _explain(same, same, files_ok=True)
    assert "CPU-dependent kernels" in line and "changed" not in line
    here = {**same, "numpy_simd": "baseline X86_V2; dispatch X86_V3 X86_V4"}
    there = {**same, "numpy_simd": "baseline X86_V2; dispatch X86_V3"}
    [line] = _explain(here, there, files_ok=True)
    assert "numpy_simd: baseline X86_V2; dispatch X86_V3 X86_V4 here" in line
    [line] = _explain(same, same, files_ok=False)
    assert "changed or damaged after generation" in line
    lines = _explain({**same, "pybullet": "3.2.6"}, same, files_ok=True)
    assert lines[0].startswith("pybullet: 3.2.6 here")
