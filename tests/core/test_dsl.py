"""The DSL: signatures file vs dispatch table, type checking, execution semantics."""

from __future__ import annotations

import pytest

from nsrmp_bench.dsl.executor import HANDLERS, execute, execute_grounded
from nsrmp_bench.dsl.program import GroundedStep, Node, Program, load_signatures
from nsrmp_bench.errors import (
    AmbiguousReference,
    BadProgram,
    InfeasibleStep,
    InvalidReference,
)
from nsrmp_bench.scene import Pose, Scene, SceneObject

Z = 0.65


def _scene(*items: tuple[str, str, float, float]) -> Scene:
    objs = tuple(SceneObject(s, c) for s, c, _, _ in items)
    poses = tuple(
        Pose((x, y, 0.625 + o.extents[2] / 2)) for o, (_, _, x, y) in zip(objs, items, strict=True)
    )
    return Scene(objs, poses)


def _ref(nodes: list[Node], *concepts: str) -> int:
    nodes.append(Node("scene"))
    for c in concepts:
        nodes.append(Node("filter", (len(nodes) - 1,), (c,)))
    nodes.append(Node("unique", (len(nodes) - 1,)))
    return len(nodes) - 1


def _move(action: str, subj: tuple[str, ...], ref: tuple[str, ...]) -> Program:
    nodes = [Node("idle")]
    s = _ref(nodes, *subj)
    r = _ref(nodes, *ref)
    nodes.append(Node("move", (0, s, r), (action,)))
    return Program(tuple(nodes))


def test_dispatch_table_matches_signature_file() -> None:
    assert set(HANDLERS) == set(load_signatures()["operations"])


def test_top_uses_true_heights_and_does_not_mutate() -> None:
    scene = _scene(("cube", "red", 0.0, 0.0), ("lego", "blue", 0.2, 0.1))
    before = scene.to_dict()
    result = execute(_move("top", ("red",), ("lego",)), scene)
    assert scene.to_dict() == before
    assert result.grounded == (GroundedStep("top", 0, 1),)
    x, y, z = result.final[0].position
    assert (x, y) == (0.2, 0.1)
    assert z == pytest.approx(0.625 + 0.046 + 0.025)


def test_left_right_use_yawed_footprints() -> None:
    scene = _scene(("cube", "red", 0.0, 0.0), ("cube", "blue", 0.2, 0.1))
    result = execute(_move("left", ("red",), ("blue",)), scene)
    assert result.final[0].position[0] == pytest.approx(0.2 - 0.05 - 0.03)
    rotated = Scene(scene.objects, (Pose((0.0, 0.0, Z), (0, 0, 0.3826834, 0.9238795)), scene.initial[1]))
    result = execute(_move("right", ("red",), ("blue",)), rotated)
    half_diag = 0.05 * 2**0.5 / 2
    assert result.final[0].position[0] == pytest.approx(0.2 + 0.025 + half_diag + 0.03, abs=1e-4)


def test_references_resolve_on_the_state_before_each_step() -> None:
    # the cube behind the red dice is the green cube at first; after the green cube
    # moves, "the cube behind the red dice" names the other one.
    scene = _scene(
        ("dice", "red", 0.0, -0.15), ("cube", "green", 0.0, 0.0), ("cube", "blue", 0.0, 0.15),
        ("lego", "white", 0.25, -0.15),
    )
    nodes = [Node("idle")]
    anchor = _ref(nodes, "red", "dice")
    nodes.append(Node("relate", (anchor,), ("behind",)))
    nodes.append(Node("filter", (len(nodes) - 1,), ("green",)))
    s1 = len(nodes)
    nodes.append(Node("unique", (s1 - 1,)))
    r1 = _ref(nodes, "lego")
    nodes.append(Node("move", (0, s1, r1), ("left",)))
    result = execute(Program(tuple(nodes)), scene)
    assert result.grounded[0].subject == 1


def test_invalid_and_ambiguous_references_raise_typed_errors() -> None:
    scene = _scene(("cube", "red", 0.0, 0.0), ("cube", "red", 0.2, 0.0), ("dice", "blue", -0.2, 0.1))
    with pytest.raises(AmbiguousReference, match=r"matches 2 objects .*0 \(red cube\), 1 \(red cube\).*add an attribute or a relation"):
        execute(_move("top", ("red", "cube"), ("blue",)), scene)
    with pytest.raises(InvalidReference, match=r"filter\[green\]\(scene\(\)\) matches no object"):
        execute(_move("top", ("green",), ("blue",)), scene)


def test_bad_programs_are_rejected_with_the_node_named() -> None:
    with pytest.raises(BadProgram, match="unknown operation 'fliter'"):
        Program((Node("fliter"),))
    with pytest.raises(BadProgram, match=r"node 1 \(unique\) input 0 needs object_set, but node 0 \(idle\) gives action_chain"):
        Program((Node("idle"), Node("unique", (0,))))
    with pytest.raises(BadProgram, match="'purple' is not a concept"):
        Program((Node("scene"), Node("filter", (0,), ("purple",))))
    with pytest.raises(BadProgram, match="must refer to earlier nodes"):
        Program((Node("unique", (0,)),))
    with pytest.raises(BadProgram, match="last node must give an action_chain"):
        Program((Node("scene"),))
    with pytest.raises(BadProgram, match="at least one node"):
        Program(())


def test_infeasible_grounded_steps_name_the_reason_and_fix() -> None:
    scene = _scene(("cube", "red", 0.0, 0.0), ("cube", "blue", 0.2, 0.1), ("dice", "green", 0.35, 0.1))
    with pytest.raises(InfeasibleStep, match=r"step 1: .*self_move"):
        execute_grounded(scene, [GroundedStep("top", 0, 0)])
    with pytest.raises(InfeasibleStep, match=r"off_table.*further from the table edge"):
        execute_grounded(scene, [GroundedStep("right", 0, 2)])
    with pytest.raises(InfeasibleStep, match=r"step 2: .*subject_covered"):
        execute_grounded(scene, [GroundedStep("top", 0, 1), GroundedStep("left", 1, 2)])
    with pytest.raises(InfeasibleStep, match="onto_support"):
        execute_grounded(scene, [GroundedStep("top", 0, 1), GroundedStep("top", 0, 1)])
    with pytest.raises(InfeasibleStep, match="reference_covered"):
        execute_grounded(scene, [GroundedStep("top", 0, 1), GroundedStep("top", 2, 1)])
