"""The objects' render twin draws the pixels the world draws itself.

A lean instance (no scenery visuals) is simulated in a client without a renderer and its
composite renders are drawn by a second client that keeps one pool of bodies per shape
(:mod:`nsrmp_bench.generators.world.object_twin`). These tests realise the same episodes
with the twin and without it (every body and render in the one client, as before) and
compare every byte, in an order that makes the twin reuse, recolour and hide its bodies.
"""

from __future__ import annotations

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from test_determinism import digest
from world_scenes import determinism_cases

from nsrmp_bench.generators.generate import make_episode
from nsrmp_bench.generators.world.object_twin import physics_only_client
from nsrmp_bench.generators.world.realise import realise
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.split_specs import load_split
from nsrmp_bench.storage.hashing import episode_hash

pytestmark = pytest.mark.sim


def test_the_twin_draws_the_worlds_pixels() -> None:
    cases = determinism_cases()
    order = ["crowded", "stack", "crowded", "stack"]  # 12 objects, then 3: 9 bodies hidden
    with World(object_twin=False) as alone, World() as twinned:
        for world in (alone, twinned):  # the first instance caches the background: full
            realise(*cases["stack"], world)
            assert world.render_client == world.client
        for name in order:
            expected = digest(realise(*cases[name], alone))
            assert alone.twin is None and alone.render_client == alone.client
            assert digest(realise(*cases[name], twinned)) == expected, name
            assert twinned.render_client != twinned.client
            twin = twinned.twin
            assert twin is not None and len(twin.bodies) == len(cases[name][0].objects)
        assert twin.pool_sizes == {"cube": 4, "dice": 4, "lego": 4}


def test_split_instances_are_the_same_bytes_with_the_twin() -> None:
    spec = load_split("smoke-v2")
    with World(object_twin=False) as alone, World() as twinned:
        expected = [episode_hash(make_episode(spec, "test", i, alone)) for i in range(6)]
        for i in reversed(range(6)):
            assert episode_hash(make_episode(spec, "test", i, twinned)) == expected[i], i


def test_a_full_render_after_a_lean_instance_uses_the_worlds_own_client() -> None:
    scene, states, steps = determinism_cases()["stack"]
    with World() as fresh:
        expected = digest(realise(scene, states, steps, fresh, composite=False))
    with World() as world:
        realise(*determinism_cases()["crowded"], world)  # caches the background
        realise(*determinism_cases()["crowded"], world)  # lean: the twin draws it
        assert world.render_client != world.client
        assert digest(realise(scene, states, steps, world, composite=False)) == expected
        assert world.render_client == world.client


def test_the_physics_only_client_has_no_renderer() -> None:
    import pybullet as pb

    client = physics_only_client(pb)
    try:
        box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.1] * 3,
                                      physicsClientId=client)
        body = pb.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=box,
                                  physicsClientId=client)
        with pytest.raises(pb.error, match="visual shape"):
            pb.getVisualShapeData(body, physicsClientId=client)
        pb.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
        pb.stepSimulation(physicsClientId=client)  # physics runs
        assert pb.getBasePositionAndOrientation(body, physicsClientId=client)[0][2] < 0.0
    finally:
        pb.disconnect(physicsClientId=client)
