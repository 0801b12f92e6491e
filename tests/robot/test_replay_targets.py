"""From predictions to robot targets: back-projecting boxes, supports, order, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from robot_cases import generated

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.generators.replay.plan import (
    PlannedMove,
    box_of,
    fit_box_on_plane,
    order_moves,
    plan_from_boxes,
    plan_from_positions,
    plan_from_program,
)
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA
from nsrmp_bench.geometry.projection import states_boxes
from nsrmp_bench.scene import Pose, SceneObject, yaw_quaternion
from nsrmp_bench.vocabulary import EXTENTS, TABLE_TOP_Z


@pytest.mark.parametrize("shape", ["cube", "dice", "lego"])
@pytest.mark.parametrize(("x", "y", "level"), [(0.0, 0.0, 0), (-0.3, -0.2, 0), (0.33, 0.2, 0),
                                               (0.1, -0.1, 1), (-0.2, 0.15, 2)])
def test_a_box_back_projects_to_the_centre_that_made_it(shape: str, x: float, y: float,
                                                        level: int) -> None:
    obj = SceneObject(shape, "red")
    z = TABLE_TOP_Z + level * 0.05 + EXTENTS[shape][2] / 2.0
    orn = yaw_quaternion(0.6)
    box = box_of(OFFICIAL_CAMERA, obj, (x, y, z), orn)
    point = fit_box_on_plane(OFFICIAL_CAMERA, obj, orn, box, z)
    assert point is not None
    assert np.abs(point - (x, y, z)).max() < 5e-4


def test_gold_final_boxes_give_the_gold_moves_and_supports() -> None:
    # a 3-step program with a stack: boxes alone say where everything went
    for index in range(6):
        ep = generated(7, 3, 100 + index, "any")
        boxes = states_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.states)
        plan = plan_from_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.scene.initial, boxes[-1])
        final = ep.states[-1]
        moved = {i for i in range(len(ep.scene)) if math.dist(final[i].position,
                                                                ep.scene.initial[i].position) > 0.01}
        assert {m.subject for m in plan.moves} == moved
        assert not plan.refused
        for m in plan.moves:
            assert math.dist(m.xy, final[m.subject].position[:2]) < 1e-3
            bottom = final[m.subject].position[2] - ep.scene.objects[m.subject].extents[2] / 2
            if m.support < 0:
                assert bottom == pytest.approx(TABLE_TOP_Z, abs=1e-4)
            else:
                s = final[m.support]
                assert bottom == pytest.approx(
                    s.position[2] + ep.scene.objects[m.support].extents[2] / 2, abs=1e-4)
        # an object is moved before anything that ends on top of it
        order = [m.subject for m in plan.moves]
        for m in plan.moves:
            if m.support in order:
                assert order.index(m.support) < order.index(m.subject)


def test_initial_boxes_plan_no_move() -> None:
    ep = generated(10, 1, 110)
    boxes = states_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.states)
    plan = plan_from_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.scene.initial, boxes[0])
    assert plan.moves == () and plan.refused == ()


def test_positions_plan_uses_the_nearest_support_below() -> None:
    ep = generated(6, 2, 111)
    pos = np.array([p.position for p in ep.states[-1]])
    plan = plan_from_positions(ep.scene.objects, ep.scene.initial, pos)
    assert {m.subject for m in plan.moves} == {
        i for i in range(len(pos)) if math.dist(pos[i], ep.scene.initial[i].position) > 0.01}
    for m in plan.moves:
        z = pos[m.subject][2] - ep.scene.objects[m.subject].extents[2] / 2
        if m.support < 0:
            assert z == pytest.approx(TABLE_TOP_Z, abs=1e-4)
        else:
            assert z > TABLE_TOP_Z + 0.02


def test_a_program_plan_keeps_feasible_steps_and_names_refused_ones() -> None:
    objects = (SceneObject("cube", "red"), SceneObject("cube", "blue"),
               SceneObject("lego", "green"))
    initial = tuple(Pose((x, 0.0, TABLE_TOP_Z + EXTENTS[o.shape][2] / 2)) for x, o in
                    zip((-0.2, 0.0, 0.2), objects, strict=True))
    steps = [GroundedStep("top", 0, 1), GroundedStep("top", 2, 1), GroundedStep("left", 1, 2),
             GroundedStep("right", 2, 2)]
    plan = plan_from_program(objects, initial, steps)
    assert [m.step for m in plan.moves] == [steps[0]]
    assert len(plan.refused) == 3
    assert "step 2" in plan.refused[0] and "reference_covered" in plan.refused[0]
    assert "step 3" in plan.refused[1] and "subject_covered" in plan.refused[1]
    assert "step 4" in plan.refused[2] and "self_move" in plan.refused[2]


def test_moves_are_ordered_top_down_and_supports_first() -> None:
    objects = (SceneObject("cube", "red"), SceneObject("cube", "blue"),
               SceneObject("cube", "green"))
    z0 = TABLE_TOP_Z + 0.025
    # object 1 rests on object 0 initially; both move; object 2 ends on object 0
    initial = (Pose((0.0, 0.0, z0)), Pose((0.0, 0.0, z0 + 0.05)), Pose((0.2, 0.0, z0)))
    moves = [PlannedMove(0, (-0.2, 0.1), -1), PlannedMove(1, (0.1, -0.1), -1),
             PlannedMove(2, (-0.2, 0.1), 0, (-0.2, 0.1))]
    plan = order_moves(objects, initial, "boxes", moves)
    assert [m.subject for m in plan.moves] == [1, 0, 2]
    # object 0 alone cannot move while object 1 stays on it
    plan = order_moves(objects, initial, "boxes", [moves[0]])
    assert plan.moves == () and "covered" in plan.refused[0]
