"""The Gymnasium environment on a real generated part (smoke-v2/test): the checker,
reset by instance and by seed, both action forms, success, truncation, determinism and
the bad-input errors."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")

from nsrmp_bench.envs.tabletop import TabletopEnv  # noqa: E402
from nsrmp_bench.episode_views import episode_boxes  # noqa: E402
from nsrmp_bench.errors import InvalidAction, InvalidArgument, ResetNeeded, UnknownId  # noqa: E402
from nsrmp_bench.storage import open as open_storage  # noqa: E402

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def env(smoke_v2_test: Path) -> Iterator[TabletopEnv]:
    e = TabletopEnv(smoke_v2_test, boxes="gold", render_mode="rgb_array")
    yield e
    e.close()


@pytest.fixture(scope="module")
def episodes(smoke_v2_test: Path) -> list[Any]:
    with open_storage(smoke_v2_test) as c:
        return list(c.iter_episodes(images=False))


def _oracle_actions(ep: Any) -> list[dict[str, Any]]:
    return [{"step": (s.action, s.subject, s.reference)} for s in ep.symbolic.grounded]


def test_registered_on_import_and_made_by_id(smoke_v2_test: Path) -> None:
    import nsrmp_bench.envs

    gym.register_envs(nsrmp_bench.envs)
    assert "nsrmp_bench/Tabletop-v0" in gym.registry
    env = gym.make("nsrmp_bench/Tabletop-v0", data=str(smoke_v2_test), part="test")
    try:
        obs, info = env.reset(seed=3)
        assert env.observation_space.contains(obs)
        assert info["step"] == 0 and info["instance"].startswith("smoke-v2-test-")
    finally:
        env.close()


def test_check_env_passes(smoke_v2_test: Path) -> None:
    from gymnasium.utils.env_checker import check_env

    for boxes in (None, "gold"):
        env = TabletopEnv(smoke_v2_test, boxes=boxes, render_mode="rgb_array")
        try:
            check_env(env, skip_render_check=False)
        finally:
            env.close()


def test_reset_starts_the_named_instance_as_generated(env: TabletopEnv,
                                                     episodes: list[Any]) -> None:
    ep = episodes[5]
    obs, info = env.reset(options={"instance": ep.id})
    assert info["instance"] == ep.id and info["step"] == 0
    assert obs["instruction"] == ep.symbolic.instruction.text
    assert obs["rgb"].shape == (240, 320, 3) and obs["depth"].dtype == np.float32
    n = ep.symbolic.num_objects
    gold0 = episode_boxes(ep)[0]
    # staged exactly as generation does: the same settled boxes
    np.testing.assert_allclose(info["boxes"], gold0, atol=0.5)
    np.testing.assert_allclose(obs["boxes"][:n], gold0, atol=0.5)
    assert obs["object_mask"].sum() == n and not obs["boxes"][n:].any()
    np.testing.assert_allclose(obs["camera"]["intrinsics"], ep.rendering.camera.intrinsics)
    assert env.observation_space.contains(obs)
    # by index too
    _, info2 = env.reset(options={"instance": 5})
    assert info2["instance"] == ep.id


def test_oracle_steps_succeed_and_done_terminates(env: TabletopEnv,
                                                 episodes: list[Any]) -> None:
    for ep in episodes[:4]:
        _, info = env.reset(options={"instance": ep.id})
        assert not info["is_success"]
        for k, action in enumerate(_oracle_actions(ep)):
            _, reward, terminated, truncated, info = env.step(action)
            assert (reward, terminated, truncated) == (0.0, False, False)
            assert info["step"] == k + 1 and info["moved"] == action["step"][1]
        assert info["is_success"], (ep.id, info["iou_m"])
        _, reward, terminated, truncated, info = env.step({"done": 1})
        assert terminated and not truncated and reward == 1.0
        assert info["step"] == ep.symbolic.num_steps
        with pytest.raises(ResetNeeded, match="ended"):
            env.step({"done": 1})


def test_pick_and_place_in_image_points_carries_out_a_step(env: TabletopEnv,
                                                           episodes: list[Any]) -> None:
    ep = next(e for e in episodes if e.symbolic.num_steps == 1)
    _, info = env.reset(options={"instance": ep.id})
    s = ep.symbolic.grounded[0].subject
    # pick: a pixel of the subject in the observed segmentation; place: where its gold
    # final centre projects
    seg = env._images.segmentation
    rows, cols = np.nonzero(seg == s)
    pick = (float(cols[len(cols) // 2]) + 0.5, float(rows[len(rows) // 2]) + 0.5)
    final = np.asarray(ep.rendering.targets.poses)[-1, s, :3]
    uv, _ = env.camera.project(final[None])
    _, _, terminated, _, info = env.step({"pick": pick, "place": uv[0].tolist(), "done": 0})
    assert info["moved"] == s and info["failure"] is None and not terminated
    assert info["is_success"], info["iou_m"]
    pred = env.prediction()
    assert pred.program is None and pred.step_boxes is not None
    np.testing.assert_allclose(pred.boxes, info["boxes"])


def test_a_miss_moves_nothing_and_the_episode_truncates(env: TabletopEnv,
                                                       episodes: list[Any]) -> None:
    ep = episodes[0]
    env.reset(options={"instance": ep.id})
    before = env.prediction().boxes
    seg = env._images.segmentation
    rows, cols = np.nonzero(seg < 0)
    empty = (float(cols[0]) + 0.5, float(rows[0]) + 0.5)
    limit = ep.symbolic.num_steps + env.step_margin
    for k in range(limit):
        _, reward, terminated, truncated, info = env.step(
            {"pick": empty, "place": empty, "done": 0})
        assert info["moved"] is None and "no object at the pick point" in info["failure"]
        assert truncated == (k == limit - 1) and not terminated
    assert reward == 0.0 and info["max_steps"] == limit
    np.testing.assert_allclose(info["boxes"], before, atol=1e-3)


def test_determinism_under_seed(smoke_v2_test: Path) -> None:
    runs = []
    for _ in range(2):
        env = TabletopEnv(smoke_v2_test, boxes="gold")
        try:
            obs, info = env.reset(seed=11)
            ep = env.episode
            assert ep is not None
            frames = [obs["rgb"]]
            for a in _oracle_actions(ep):
                obs, *_ = env.step(a)
                frames.append(obs["rgb"])
            runs.append((info["instance"], frames, env.prediction().positions))
        finally:
            env.close()
    assert runs[0][0] == runs[1][0]
    for a, b in zip(runs[0][1], runs[1][1], strict=True):
        assert np.array_equal(a, b)
    assert np.array_equal(runs[0][2], runs[1][2])


def test_render_rgb_array(env: TabletopEnv) -> None:
    obs, _ = env.reset(seed=0)
    frame = env.render()
    assert frame is not None and np.array_equal(frame, obs["rgb"])


def test_bad_input_is_refused_with_the_value_and_the_fix(env: TabletopEnv,
                                                         smoke_v2_test: Path) -> None:
    fresh = TabletopEnv(smoke_v2_test)
    try:
        with pytest.raises(ResetNeeded, match="before reset"):
            fresh.step({"done": 1})
    finally:
        fresh.close()
    with pytest.raises(UnknownId, match=r"'smoke-v2-test-999999'.*smoke-v2-test-000000"):
        env.reset(options={"instance": "smoke-v2-test-999999"})
    with pytest.raises(UnknownId, match=r"instance 16 is out of range.*0..15"):
        env.reset(options={"instance": 16})
    with pytest.raises(InvalidArgument, match="unknown reset option"):
        env.reset(options={"episode": 1})
    env.reset(options={"instance": 0})
    with pytest.raises(InvalidAction, match=r"pick point \(400.0, 10.0\) lies outside the "
                                            r"320x240 image"):
        env.step({"pick": (400, 10), "place": (10, 10), "done": 0})
    with pytest.raises(InvalidAction, match=r"subject is object 99.*objects 0\.\.\d+"):
        env.step({"step": ("top", 99, 0)})
    with pytest.raises(InvalidAction, match="unknown step action 'under'"):
        env.step({"step": ("under", 0, 1)})
    with pytest.raises(InvalidAction, match="unknown action key"):
        env.step({"pick": (1, 1), "place": (2, 2), "jump": 1})
    with pytest.raises(InvalidAction, match="needs both 'pick' and 'place'"):
        env.step({"pick": (1, 1)})
    with pytest.raises(InvalidArgument, match="boxes='detected'"):
        TabletopEnv(smoke_v2_test, boxes="detected")
    with pytest.raises(InvalidArgument, match="executor='arm'"):
        TabletopEnv(smoke_v2_test, executor="arm")
    with pytest.raises(InvalidArgument, match=r"needs data=.*or split="):
        TabletopEnv()


def test_generated_on_the_fly_from_a_split_spec() -> None:
    env = TabletopEnv(split="smoke-v2", part="test", boxes="gold")
    try:
        obs, info = env.reset(options={"instance": "smoke-v2-test-000002"})
        assert info["instance"] == "smoke-v2-test-000002"
        assert env.observation_space.contains(obs)
    finally:
        env.close()


def test_the_envs_package_registers_in_any_import_order() -> None:
    import subprocess
    import sys

    for first, then in (("gymnasium as gym", "nsrmp_bench.envs"),
                        ("nsrmp_bench.envs", "gymnasium as gym")):
        code = (f"import {first}; import {then}; import gymnasium as gym, nsrmp_bench.envs; "
                "gym.register_envs(nsrmp_bench.envs); "
                "assert 'nsrmp_bench/Tabletop-v0' in gym.registry; "
                "import sys; assert 'pybullet' not in sys.modules")
        subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
    # the package root registers nothing, in either order; the module-prefixed id works
    code = ("import gymnasium as gym, nsrmp_bench, sys; "
            "assert 'nsrmp_bench/Tabletop-v0' not in gym.registry; "
            "gym.make('nsrmp_bench.envs:nsrmp_bench/Tabletop-v0', split='smoke-v2').close()")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)



def test_robot_executor_carries_out_the_oracle(smoke_v2_test: Path,
                                               episodes: list[Any]) -> None:
    ep = next(e for e in episodes if e.symbolic.num_steps == 1)
    env = TabletopEnv(smoke_v2_test, executor="robot")
    try:
        env.reset(options={"instance": ep.id})
        for a in _oracle_actions(ep):
            _, _, _, _, info = env.step(a)
        assert info["is_success"], info["iou_m"]
        _, reward, terminated, _, _ = env.step({"done": 1})
        assert terminated and reward == 1.0
    finally:
        env.close()


def test_what_a_person_says_replaces_the_instruction_and_is_checked(env: TabletopEnv) -> None:
    from nsrmp_bench.instruction_check import MAX_INSTRUCTION_CHARS

    obs, _ = env.reset(options={"instance": 0, "instruction": "Go ahead."})
    assert obs["instruction"] == "Go ahead."
    obs, _ = env.reset(options={"instance": 0})
    assert obs["instruction"] == env.episode.symbolic.instruction.text  # type: ignore[union-attr]
    for value, match in ((None, "NoneType"), ("   ", "whitespace"), (b"go", "bytes"),
                         ("x" * (MAX_INSTRUCTION_CHARS + 1), f"at most {MAX_INSTRUCTION_CHARS}"), ("Put it \u2192 there.", "printable")):
        with pytest.raises(InvalidArgument, match=match):
            env.reset(options={"instance": 0, "instruction": value})
