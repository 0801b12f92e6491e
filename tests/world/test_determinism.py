"""Same inputs, same bytes: whatever the process realised before, in any process."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from world_scenes import determinism_cases

from nsrmp_bench.generators.world.realise import realise

pytestmark = pytest.mark.sim

_HERE = Path(__file__).parent


def digest(rendering: Any) -> str:
    """sha256 over every array of a rendering, in a fixed order."""
    h = hashlib.sha256()
    obs, tg = rendering.observations, rendering.targets
    for arr in (obs.rgb, obs.depth, obs.segmentation, tg.poses, tg.boxes_amodal,
                tg.boxes_visible, tg.visible_fraction, tg.depth_centre):
        a = np.ascontiguousarray(arr)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.tobytes())
    h.update(json.dumps(rendering.physics, sort_keys=True).encode())
    return h.hexdigest()


def realise_all(world: Any, order: list[str]) -> dict[str, str]:
    cases = determinism_cases()
    return {name: digest(realise(*cases[name], world)) for name in order}


_CHILD = """
import json, sys
sys.path.insert(0, {here!r})
from test_determinism import realise_all
from nsrmp_bench.generators.world.world import World
with World() as w:
    print(json.dumps(realise_all(w, {order!r})))
"""


def test_an_episode_does_not_depend_on_what_the_world_did_before(world: Any) -> None:
    cases = determinism_cases()
    seen: dict[str, set[str]] = {}
    for name in ["crowded", "stack", "crowded", "stack", "stack", "crowded"]:
        seen.setdefault(name, set()).add(digest(realise(*cases[name], world)))
    assert all(len(d) == 1 for d in seen.values()), seen


def test_another_process_realises_the_same_bytes(world: Any) -> None:
    here = realise_all(world, ["stack", "crowded"])
    code = _CHILD.format(here=str(_HERE), order=["crowded", "stack"])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    there = json.loads(out.stdout.strip().splitlines()[-1])
    assert there == here


def test_an_instance_realised_after_another_equals_it_realised_first() -> None:
    """The v1 world kept Bullet's broadphase history across instances: objects-v1/test
    000643 realised right after 000642 differed in its last bits from 000643 realised
    first (why the v1 splits were withdrawn). Every instance now starts from a reset simulation."""
    from nsrmp_bench.generators.generate import make_episode
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.split_specs import load_split
    from nsrmp_bench.storage.hashing import episode_hash

    spec = load_split("objects-v2")
    with World() as after:
        make_episode(spec, "test", 642, after)
        second = episode_hash(make_episode(spec, "test", 643, after))
    with World() as fresh:
        first = episode_hash(make_episode(spec, "test", 643, fresh))
    assert second == first


def test_the_lean_reset_loads_the_same_collision_shapes() -> None:
    """The Panda's collision meshes read from copies that hold only what Bullet's collision
    import reads, with no visuals in the physics-only client (1 mm boxes where a renderer
    could draw it), and the table without its visuals, give the same hulls (vertices in
    the same order), shapes, boxes, dynamics and joints as the shipped files."""
    from nsrmp_bench.generators.world.world import World

    def shapes(world: World) -> list[object]:
        pb, c = world.pb, world.client
        out: list[object] = []
        for body in (world.table, world.panda):
            for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
                out.append(pb.getMeshData(body, link, physicsClientId=c))
                # type, dimensions and frame (not the mesh's file name: a lean copy)
                out.append([(*d[:4], *d[5:]) for d in
                            pb.getCollisionShapeData(body, link, physicsClientId=c)])
                out.append(pb.getAABB(body, link, physicsClientId=c))
                out.append(pb.getDynamicsInfo(body, link, physicsClientId=c))
                if link >= 0:
                    out.append(pb.getJointInfo(body, link, physicsClientId=c))
        return out

    class Loads:
        """PyBullet, with the files ``loadURDF`` was given noted."""

        def __init__(self, pb: Any) -> None:
            self.pb, self.files = pb, []

        def __getattr__(self, name: str) -> Any:
            return getattr(self.pb, name)

        def loadURDF(self, path: str, *args: Any, **kwargs: Any) -> Any:
            self.files.append(Path(path).name)
            return self.pb.loadURDF(path, *args, **kwargs)

    with World(lean_reset=False) as shipped, World() as lean, \
            World(object_twin=False) as drawn:
        want = shapes(shipped)
        for world in (lean, drawn):
            world.pb = Loads(world.pb)
            world.begin((), scenery_visuals=False)
        assert lean.panda is not None and lean.client != lean.render_client
        assert drawn.client == drawn.render_client  # a client with a renderer
        # the physics-only client: both files without visuals; with a renderer, the
        # table without visuals and the arm with its stand-ins
        assert lean.pb.files[0].startswith("table_physics_"), lean.pb.files
        assert drawn.pb.files[0].startswith("table_physics_"), drawn.pb.files
        assert "<visual" not in Path(lean._bare_panda_urdfs[True, False]).read_text()
        assert "<visual>" in Path(drawn._bare_panda_urdfs[False, False]).read_text()
        assert lean.pb.files[1] == Path(lean._bare_panda_urdfs[True, False]).name
        assert drawn.pb.files[1] == Path(drawn._bare_panda_urdfs[False, False]).name
        assert shapes(lean) == want
        assert shapes(drawn) == want
        meshes = [m for m in shapes(lean) if isinstance(m, tuple) and len(m) == 2
                  and isinstance(m[1], tuple) and m[1] and isinstance(m[1][0], tuple)]
        assert sum(len(m[1]) for m in meshes) > 1000  # the hulls' vertices were compared


def test_the_reduced_arm_keeps_its_bounding_boxes_dynamics_and_joints() -> None:
    """``begin(..., robot_collision=False)``: each of the arm's hulls from the six points
    that bound it; every link's box, dynamics and joint are the shipped arm's to the bit
    (the broadphase sees the same arm), at a fraction of the hull points."""
    from nsrmp_bench.generators.world.world import World

    def links(world: World) -> tuple[list[object], int]:
        pb, c, body = world.pb, world.client, world.panda
        out: list[object] = []
        points = 0
        for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
            out.append(pb.getAABB(body, link, physicsClientId=c))
            out.append(pb.getDynamicsInfo(body, link, physicsClientId=c))
            if link >= 0:
                out.append(pb.getJointInfo(body, link, physicsClientId=c))
            points += pb.getMeshData(body, link, physicsClientId=c)[0]
        return out, points

    with World(lean_reset=False) as shipped, World() as reduced:
        reduced.begin((), scenery_visuals=False, robot_collision=False)
        assert not reduced.robot_collision
        got, few = links(reduced)
        want, many = links(shipped)
        assert got == want
        assert 0 < few <= 6 * 11 < many
