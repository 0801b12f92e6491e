"""Teleport instances run with the resting arm's hulls reduced to their bounding points,
and with them whole when an object comes near.

The arm stands folded at rest, clear of the workspace, and touches nothing in a teleport
instance; hulls with the same bounding boxes leave the broadphase as it was, so no byte
changes (every committed part is reproduced: README, "Generation speed") and the reset
skips most of the hull computation. An instance whose objects come within
``ROBOT_CLEARANCE`` of the arm's resting boxes is realised again with the hulls whole.
"""

from __future__ import annotations

from typing import Any, Final

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from test_determinism import digest
from world_scenes import chain, on_table, scene_of

from nsrmp_bench.generators.world.realise import PhysicsRejection, TeleportPlacer, realise
from nsrmp_bench.scene import Scene

pytestmark = pytest.mark.sim


class _WithArm(TeleportPlacer):
    """Teleport-and-settle with the arm's hulls whole (the build before this one)."""

    moves_robot: Final = True  # type: ignore[misc]


def _scene(y: float) -> Scene:
    return scene_of([
        ("cube", "red", on_table("cube", 0.0, 0.0)),
        ("dice", "blue", on_table("dice", 0.2, 0.05, yaw=0.4)),
        ("lego", "green", on_table("lego", -0.05, y, yaw=0.3)),
    ])


def _realise(world: Any, scene: Scene, placer: TeleportPlacer | None = None) -> Any:
    states, steps = chain(scene, [("left", 1, 0, on_table("dice", -0.1, -0.12, yaw=0.4))])
    return realise(scene, states, steps, world, placer=placer)


def test_a_teleport_instance_reduces_the_arm_and_makes_the_same_bytes(world: Any) -> None:
    scene = _scene(0.1)
    _realise(world, scene)  # the background is cached from here on
    reduced = digest(_realise(world, scene))
    assert not world.robot_collision and not world.near_robot()
    whole = digest(_realise(world, scene, _WithArm()))
    assert world.robot_collision
    assert reduced == whole


def test_an_object_near_the_arm_makes_its_hulls_whole(world: Any) -> None:
    scene = _scene(0.38)  # the lego's far side 2-3 cm from the arm's base
    _realise(world, _scene(0.1))
    assert not world.robot_collision
    near = _realise(world, scene)
    assert world.robot_collision and world.near_robot()
    assert digest(near) == digest(_realise(world, scene, _WithArm()))


def test_an_object_placed_into_the_arm_is_a_penetration(world: Any) -> None:
    # the check sees the arm as it is: its hulls are whole as soon as an object is near
    scene = scene_of([("cube", "red", on_table("cube", 0.0, 0.0)),
                      ("cube", "blue", on_table("cube", 0.0, 0.45))])
    with pytest.raises(PhysicsRejection) as info:
        realise(scene, *chain(scene, []), world)
    assert info.value.reason == "penetration" and info.value.object_index == 1
    assert "the table or robot" in str(info.value)
