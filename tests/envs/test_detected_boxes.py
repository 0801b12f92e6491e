"""The environment's detector boxes (``boxes="classical"`` / ``"learned"``) on a real
generated part (smoke-v2/test): stated in the observation space, equal to what
``nsrmp-bench detect`` finds on the stored initial image, and following the scene as it
changes."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")
pytest.importorskip("scipy")

from nsrmp_bench.detection.classical import classical_detect
from nsrmp_bench.envs.tabletop import TabletopEnv
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.matching import hungarian_match
from nsrmp_bench.storage import open as open_storage

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def classical_env(smoke_v2_test: Path) -> Iterator[TabletopEnv]:
    e = TabletopEnv(smoke_v2_test, boxes="classical")
    yield e
    e.close()


def test_the_observation_space_states_detected_boxes(smoke_v2_test: Path,
                                                     classical_env: TabletopEnv) -> None:
    assert {"boxes", "object_mask", "box_scores"} <= set(classical_env.observation_space.keys())
    gold = TabletopEnv(smoke_v2_test, boxes="gold")
    plain = TabletopEnv(smoke_v2_test)
    try:
        assert set(gold.observation_space.keys()) >= {"boxes", "object_mask"}
        assert "box_scores" not in set(gold.observation_space.keys())
        assert not {"boxes", "box_scores"} & set(plain.observation_space.keys())
    finally:
        gold.close()
        plain.close()


def test_initial_detections_are_the_detect_verbs(classical_env: TabletopEnv,
                                                 smoke_v2_test: Path) -> None:
    with open_storage(smoke_v2_test) as collection:
        camera = collection.episode(0, images=False).rendering.camera
        for i in range(4):
            inp = collection.read_inputs(i)
            want = classical_detect(str(inp["id"]), inp["rgb"], inp["depth"], camera)
            obs, _ = classical_env.reset(options={"instance": i})
            assert classical_env.observation_space.contains(obs)
            k = len(want)
            assert int(obs["object_mask"].sum()) == k > 0
            np.testing.assert_allclose(obs["boxes"][:k], want.boxes, atol=1e-4)
            np.testing.assert_allclose(obs["box_scores"][:k], want.scores, atol=1e-6)
            assert not obs["boxes"][k:].any() and not obs["box_scores"][k:].any()


def test_detections_follow_the_scene_after_each_move(classical_env: TabletopEnv,
                                                     smoke_v2_test: Path) -> None:
    matched = total = 0
    with open_storage(smoke_v2_test) as collection:
        episodes = [collection.episode(i, images=False) for i in range(6)]
    for ep in episodes:
        obs, info = classical_env.reset(options={"instance": ep.id})
        before = obs["boxes"].copy()
        for s in ep.symbolic.grounded:
            obs, _, _, _, info = classical_env.step({"step": (s.action, s.subject,
                                                              s.reference)})
            assert classical_env.observation_space.contains(obs)
            k = int(obs["object_mask"].sum())
            m = hungarian_match(info["boxes"], obs["boxes"][:k].astype(np.float64), 0.5)
            matched += int((m >= 0).sum())
            total += len(info["boxes"])
        if ep.symbolic.grounded:
            assert not np.array_equal(before, obs["boxes"]), ep.id  # detected anew
    assert matched / total >= 0.85, (matched, total)


def test_check_env_passes_with_a_detector(smoke_v2_test: Path) -> None:
    from gymnasium.utils.env_checker import check_env

    env = TabletopEnv(smoke_v2_test, boxes="classical")
    try:
        check_env(env)
    finally:
        env.close()


def test_the_learned_detector(smoke_v2_test: Path) -> None:
    pytest.importorskip("torch")
    env = TabletopEnv(smoke_v2_test, boxes="learned")
    try:
        obs, info = env.reset(options={"instance": 2})
        assert env.observation_space.contains(obs)
        k = int(obs["object_mask"].sum())
        assert k > 0 and (obs["box_scores"][:k] > 0).all()
        m = hungarian_match(info["boxes"], obs["boxes"][:k].astype(np.float64), 0.5)
        assert (m >= 0).sum() >= len(info["boxes"]) - 1
    finally:
        env.close()


def test_an_unknown_boxes_value_names_the_choices(smoke_v2_test: Path) -> None:
    with pytest.raises(InvalidArgument, match=r"boxes='yolo' is not one of \[None, 'gold', "
                                              r"'classical', 'learned'\]"):
        TabletopEnv(smoke_v2_test, boxes="yolo")
