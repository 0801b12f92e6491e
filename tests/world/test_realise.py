"""realise(): stable stacks, per-state targets, and every rejection reason on a bad case."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from world_scenes import chain, on_table, on_top, scene_of

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.generators.world.realise import (
    REJECTION_REASONS,
    PhysicsRejection,
    Tolerances,
    realise,
)
from nsrmp_bench.scene import Pose, Scene
from nsrmp_bench.vocabulary import EXTENTS, TABLE_TOP_Z

pytestmark = pytest.mark.sim


def _three(first: str = "cube", second: str = "dice", third: str = "lego") -> Scene:
    return scene_of([
        (first, "red", on_table(first, 0.0, 0.0)),
        (second, "blue", on_table(second, 0.2, 0.05, yaw=0.4)),
        (third, "green", on_table(third, -0.2, 0.1, yaw=1.0)),
    ])


@pytest.mark.parametrize("shapes", [("cube", "dice", "lego"), ("lego", "cube", "dice"),
                                    ("dice", "lego", "cube"), ("lego", "lego", "lego")])
def test_three_high_stacks_built_step_by_step_are_stable(world: Any,
                                                          shapes: tuple[str, str, str]) -> None:
    scene = _three(*shapes)
    a = scene.initial[0]
    b = on_top(a, shapes[0], shapes[1])
    c = on_top(b, shapes[1], shapes[2])
    states, steps = chain(scene, [("top", 1, 0, b), ("top", 2, 1, c)])
    r = realise(scene, states, steps, world)
    top = TABLE_TOP_Z + sum(EXTENTS[s][2] for s in shapes) - EXTENTS[shapes[2]][2] / 2
    assert r.targets.poses[2, 2, 2] == pytest.approx(top, abs=5e-4)
    assert max(r.physics["max_drift_m"]) < 1e-3
    assert max(r.physics["max_tilt_deg"]) < 1.0
    assert r.targets.poses.shape == (3, 3, 7)
    assert r.observations is not None and r.observations.rgb.shape[0] == 3
    assert r.executor == "teleport"
    canonical_json(r.physics)  # strict JSON: stored and hashed as is


def test_objects_that_do_not_move_keep_their_pose_and_boxes(world: Any) -> None:
    scene = _three()
    states, steps = chain(scene, [("left", 1, 0, on_table("dice", -0.1, -0.12, yaw=0.4))])
    r = realise(scene, states, steps, world)
    p = r.targets.poses
    assert np.abs(p[1, [0, 2]] - p[0, [0, 2]]).max() < 2e-4
    assert np.abs(r.targets.boxes_amodal[1, [0, 2]] - r.targets.boxes_amodal[0, [0, 2]]).max() < 0.1
    assert np.abs(p[1, 1, :2] - [-0.1, -0.12]).max() < 1e-3


def _reject(world: Any, scene: Scene, moves: list[Any], **kw: Any) -> PhysicsRejection:
    states, steps = chain(scene, moves)
    with pytest.raises(PhysicsRejection) as info:
        realise(scene, states, steps, world, **kw)
    err = info.value
    assert isinstance(err, GenerationError)
    assert err.reason in REJECTION_REASONS
    assert "resample" in str(err)
    canonical_json(err.to_dict())
    return err


def test_a_target_in_mid_air_makes_the_object_fall(world: Any) -> None:
    err = _reject(world, _three(), [("top", 1, 0, Pose((0.1, 0.1, 0.8)))])
    assert err.reason == "fell" and err.step == 1 and err.object_index == 1
    assert err.value == pytest.approx(0.8 - (TABLE_TOP_Z + 0.025), abs=2e-3)
    assert "blue dice" in str(err) and "10 mm" in str(err)


def test_a_target_off_the_table_is_rejected(world: Any) -> None:
    err = _reject(world, _three(), [("left", 1, 0, on_table("dice", -0.9, 0.0))])
    assert err.reason == "off_table" and err.object_index == 1
    assert "-0.900" in str(err)


def test_an_object_placed_over_the_edge_falls_off_the_table(world: Any) -> None:
    # an initial pose whose centre hangs just beyond the edge: it tips off and drops
    scene = scene_of([("cube", "red", on_table("cube", 0.0, 0.0)),
                      ("cube", "blue", on_table("cube", 0.76, 0.0))])
    err = _reject(world, scene, [])
    assert err.reason == "off_table" and err.step == 0 and err.object_index == 1
    assert "left the table" in str(err)


def test_a_target_inside_another_object_is_a_penetration(world: Any) -> None:
    err = _reject(world, _three(), [("left", 1, 0, on_table("dice", 0.03, 0.0))])
    assert err.reason == "penetration" and err.object_index == 1
    assert err.value == pytest.approx(0.02, abs=1e-3)
    assert "red cube" in str(err)


def test_an_object_that_is_not_upright_has_toppled(world: Any) -> None:
    lying = Pose((0.1, 0.0, TABLE_TOP_Z + 0.032), (0.7071068, 0.0, 0.0, 0.7071068))
    scene = scene_of([("lego", "red", lying), ("cube", "blue", on_table("cube", -0.1, 0.0))])
    err = _reject(world, scene, [])
    assert err.reason == "toppled" and err.step == 0 and err.object_index == 0
    assert err.value == pytest.approx(90.0, abs=1.0)


def test_a_neighbour_pushed_by_a_placement_is_disturbed(world: Any) -> None:
    scene = scene_of([("cube", "red", on_table("cube", 0.0, 0.0)),
                      ("cube", "blue", on_table("cube", 0.2, 0.0))])
    # 1.8 mm overlap passes the penetration check; the contact pushes the red cube ~1 mm
    target = on_table("cube", 0.0482, 0.0)
    err = _reject(world, scene, [("right", 1, 0, target)],
                  tolerances=Tolerances(disturbed=2e-4))
    assert err.reason == "disturbed" and err.object_index == 0
    assert 2e-4 < err.value < 5e-3
    realise(scene, *chain(scene, [("right", 1, 0, target)]), world)  # fine at 5 mm


def test_an_object_hidden_behind_a_stack_is_occluded(world: Any) -> None:
    s0 = on_table("cube", 0.0, 0.0)
    s1 = on_top(s0, "cube", "cube")
    s2 = on_top(s1, "cube", "cube")
    scene = scene_of([("cube", "red", s0), ("cube", "blue", s1), ("cube", "green", s2),
                      ("cube", "yellow", on_table("cube", 0.0, 0.065))])
    err = _reject(world, scene, [])
    assert err.reason == "occluded" and err.object_index == 3
    assert err.value < 0.3 and "yellow cube" in str(err)
    # the same scene passes when nothing is required to be visible
    r = realise(scene, *chain(scene, []), world, min_visible=0.0)
    assert r.targets.visible_fraction[0, 3] < 0.3
    assert np.isnan(r.targets.boxes_visible[0, 3]).all() == (r.targets.visible_fraction[0, 3] == 0)


def test_objects_still_moving_after_the_step_budget_are_unsettled(world: Any) -> None:
    err = _reject(world, _three(), [], tolerances=Tolerances(settle_max_steps=3))
    assert err.reason == "unsettled" and err.object_index is None


def test_inputs_that_do_not_fit_together_are_invalid_arguments(world: Any) -> None:
    scene = _three()
    states, steps = chain(scene, [("top", 1, 0, on_top(scene.initial[0], "cube", "dice"))])
    with pytest.raises(InvalidArgument, match="steps \\+ 1"):
        realise(scene, states[:1], steps, world)
    with pytest.raises(InvalidArgument, match=r"objects 0\.\.2"):
        realise(scene, states, (steps[0].__class__("top", 7, 0),), world)
    with pytest.raises(InvalidArgument, match="min_visible"):
        realise(scene, states, steps, world, min_visible=1.5)
    from nsrmp_bench.generators.generate import placer

    with pytest.raises(InvalidArgument, match=r"'robot-v9'.*'teleport'.*split spec"):
        placer("robot-v9")


def test_physics_only_runs_skip_the_images(world: Any) -> None:
    scene = _three()
    r = realise(scene, *chain(scene, []), world, render=False)
    assert r.observations is None
    assert np.isnan(r.targets.boxes_visible).all()
    assert not np.isnan(r.targets.boxes_amodal).any()
