"""The named step checks, one by one, on constructed states."""

from __future__ import annotations

from nsrmp_bench.dsl import actions
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.scene import Pose, SceneObject

OBJ = (SceneObject("cube", "red"), SceneObject("cube", "blue"), SceneObject("lego", "green"),
       SceneObject("dice", "white"))
FLAT = (Pose((0.0, 0.0, 0.65)), Pose((0.2, 0.1, 0.65)), Pose((-0.2, 0.0, 0.648)),
        Pose((0.0, 0.15, 0.65)))
# red cube stacked on the blue cube, white dice on the red cube: a 3-high tower
TOWER = (Pose((0.2, 0.1, 0.7)), FLAT[1], FLAT[2], Pose((0.2, 0.1, 0.75)))


def s(action: str, a: int, b: int) -> GroundedStep:
    return GroundedStep(action, a, b)


def test_is_self_move() -> None:
    assert actions.is_self_move(OBJ, FLAT, s("top", 1, 1)) == "self_move"
    assert actions.is_self_move(OBJ, FLAT, s("top", 1, 2)) is None


def test_subject_covered() -> None:
    assert actions.subject_covered(OBJ, TOWER, s("left", 0, 2)) == "subject_covered"
    assert actions.subject_covered(OBJ, TOWER, s("left", 3, 2)) is None


def test_moves_onto_support_also_lower_in_the_stack() -> None:
    assert actions.moves_onto_support(OBJ, TOWER, s("top", 3, 0)) == "onto_support"
    assert actions.moves_onto_support(OBJ, TOWER, s("top", 3, 1)) == "onto_support"
    assert actions.moves_onto_support(OBJ, TOWER, s("top", 3, 2)) is None


def test_reference_covered_and_too_high() -> None:
    assert actions.reference_covered(OBJ, TOWER, s("top", 2, 0)) == "reference_covered"
    assert actions.too_high(OBJ, TOWER, s("top", 2, 3)) == "too_high"
    assert actions.too_high(OBJ, FLAT, s("top", 2, 3)) is None


def test_off_table_and_no_change() -> None:
    edge = (Pose((0.33, 0.0, 0.65)), *FLAT[1:])
    assert actions.off_table(OBJ, edge, s("right", 1, 0)) == "off_table"
    beside = (Pose((0.12, 0.1, 0.65)), *FLAT[1:])
    assert actions.changes_nothing(OBJ, beside, s("left", 0, 1)) == "no_change"
    assert actions.changes_nothing(OBJ, FLAT, s("left", 0, 1)) is None


def test_target_occupied() -> None:
    crowded = (FLAT[0], FLAT[1], Pose((0.12, 0.1, 0.648)), FLAT[3])
    assert actions.target_occupied(OBJ, crowded, s("left", 0, 1)) == "target_occupied"
    assert actions.target_occupied(OBJ, FLAT, s("left", 0, 1)) is None


def test_feasible_steps_are_exactly_those_passing_every_check() -> None:
    steps = actions.feasible_steps(OBJ, TOWER)
    assert steps
    for step in steps:
        assert actions.step_problem(OBJ, TOWER, step) is None
    assert s("left", 0, 2) not in steps  # covered by the dice
