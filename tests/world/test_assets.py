"""Procedural assets: dice pips, lego geometry, the lean Panda URDF, resting heights."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

from world_scenes import on_table, scene_of  # noqa: E402

from nsrmp_bench.generators.world.assets import (  # noqa: E402
    DICE_FACE_PIPS,
    asset_cache_dir,
    create_shape_ids,
    dice_mesh,
    dice_texture,
    ensure_dice_textures,
    lean_panda_urdf,
    lego_parts,
    physics_urdf,
    silhouette_points,
)
from nsrmp_bench.vocabulary import COLOURS, EXTENTS, SHAPES, TABLE_TOP_Z  # noqa: E402

pytestmark = pytest.mark.sim


@pytest.mark.parametrize("colour", COLOURS)
def test_dice_texture_has_the_right_pips_on_every_face(colour: str) -> None:
    atlas = dice_texture(colour)
    face = atlas.shape[0]
    assert atlas.shape == (face, 6 * face, 3)
    body = atlas[2, 2].astype(int)
    for k, pips in enumerate(DICE_FACE_PIPS):
        cell = atlas[:, k * face:(k + 1) * face].astype(int)
        pip_mask = (np.abs(cell - body).sum(axis=2) > 150).astype(np.uint8)
        n, _ = cv2.connectedComponents(pip_mask)
        assert n - 1 == pips, f"face {k} of the {colour} dice shows {n - 1} pips, not {pips}"
    opposite = [DICE_FACE_PIPS[i] + DICE_FACE_PIPS[i + 1] for i in (0, 2, 4)]
    assert opposite == [7, 7, 7]
    assert sorted(DICE_FACE_PIPS) == [1, 2, 3, 4, 5, 6]


def test_dice_mesh_faces_point_outwards_and_map_to_their_atlas_cells() -> None:
    mesh = dice_mesh(0.05)
    v = np.asarray(mesh["vertices"])
    idx = np.asarray(mesh["indices"]).reshape(-1, 3)
    uv = np.asarray(mesh["uvs"])
    assert np.allclose(np.abs(v), 0.025)
    for tri in idx:
        a, b, c = v[tri]
        normal = np.cross(b - a, c - a)
        assert np.dot(normal, (a + b + c) / 3) > 0, "a triangle faces inwards"
    cells = np.floor(uv[:, 0] * 6).reshape(6, 4)
    assert (cells == np.arange(6)[:, None]).all()


def test_lego_parts_span_exactly_the_vocabulary_extents() -> None:
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for part in lego_parts():
        c = np.asarray(part.position)
        h = np.asarray(part.half_extents)
        lo = np.minimum(lo, c - h)
        hi = np.maximum(hi, c + h)
    assert np.allclose(hi - lo, EXTENTS["lego"], atol=1e-12)
    assert np.allclose(hi + lo, 0.0, atol=1e-12), "the body frame is the box centre"
    pts = silhouette_points("lego")
    assert np.all(np.abs(pts) <= np.asarray(EXTENTS["lego"]) / 2 + 1e-12)


def test_lean_panda_urdf_keeps_collision_meshes_only(tmp_path: Path) -> None:
    import pybullet_data

    path = lean_panda_urdf(tmp_path, pybullet_data.getDataPath())
    text = path.read_text()
    assert "meshes/visual" not in text and "package://" not in text
    meshes = [line.split('"')[1] for line in text.splitlines() if "<mesh filename=" in line]
    assert meshes and all(Path(m).is_file() for m in meshes)
    assert lean_panda_urdf(tmp_path, pybullet_data.getDataPath()) == path  # cached


def _elements(path: Path) -> list[tuple[str, dict[str, str]]]:
    """Every element of a URDF but its visuals (and what they hold), in document order."""
    root = ET.parse(path).getroot()
    for parent in list(root.iter()):
        for child in [c for c in parent if c.tag == "visual"]:
            parent.remove(child)
    return [(el.tag, dict(el.attrib)) for el in root.iter()]


def test_physics_only_urdfs_are_the_files_without_their_visuals(tmp_path: Path) -> None:
    import pybullet_data

    data = pybullet_data.getDataPath()
    shipped_table = Path(data) / "table" / "table.urdf"
    table = physics_urdf(shipped_table, tmp_path)
    stand_ins = lean_panda_urdf(tmp_path, data, visuals=False, bounds=True)
    panda = physics_urdf(stand_ins, tmp_path)
    for path in (table, panda):
        text = path.read_text()
        assert "<visual" not in text and "<!--" not in text and "\n " not in text, path
    assert _elements(table) == _elements(shipped_table)
    assert _elements(panda) == _elements(stand_ins)
    assert "<visual>" in stand_ins.read_text()
    assert physics_urdf(shipped_table, tmp_path) == table  # named by content: cached


@pytest.mark.parametrize("bounds", [False, True])
def test_the_physics_only_arm_loads_as_the_stand_in_one_wherever_the_cache_is(
        tmp_path: Path, bounds: bool) -> None:
    """PyBullet reads a URDF line by line and breaks lines after 8,191 characters: the
    arm's file, which holds the cache's absolute paths, must load the same from a cache
    deep in the file system (a file on one line broke joints and limits there)."""
    import pybullet as pb
    import pybullet_data

    from nsrmp_bench.generators.world.object_twin import physics_only_client

    data = pybullet_data.getDataPath()
    deep = tmp_path / ("d" * 200) / ("e" * 200)
    deep.mkdir(parents=True)
    stand_ins = lean_panda_urdf(deep, data, visuals=False, bounds=bounds)
    bare = physics_urdf(stand_ins, deep)
    assert max(len(line) for line in bare.read_text().splitlines()) < 1024
    c = physics_only_client(pb)
    try:
        def links(path: Path, flags: int) -> list[object]:
            body = pb.loadURDF(str(path), useFixedBase=True, flags=flags, physicsClientId=c)
            out: list[object] = []
            for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
                out.append(pb.getAABB(body, link, physicsClientId=c))
                out.append(pb.getDynamicsInfo(body, link, physicsClientId=c))
                if link >= 0:
                    out.append(pb.getJointInfo(body, link, physicsClientId=c))
            return out

        got = links(bare, pb.URDF_IGNORE_VISUAL_SHAPES)
        assert len(got) == 13 * 3 - 1  # the base and 12 links: box and dynamics, joints
        assert got == links(stand_ins, 0)
    finally:
        pb.disconnect(physicsClientId=c)


@pytest.mark.parametrize("shape", SHAPES)
def test_shapes_without_visuals_collide_as_with_them(shape: str) -> None:
    import pybullet as pb

    c = pb.connect(pb.DIRECT)
    try:
        both = create_shape_ids(pb, c, shape)
        bare = create_shape_ids(pb, c, shape, visual=False)
        assert both.visual >= 0 and bare.visual == -1
        bodies = [pb.createMultiBody(baseMass=0.1, baseCollisionShapeIndex=ids.collision,
                                     physicsClientId=c) for ids in (both, bare)]
        a, b = ([[d[1:] for d in pb.getCollisionShapeData(body, -1, physicsClientId=c)],
                 pb.getAABB(body, -1, physicsClientId=c),
                 pb.getDynamicsInfo(body, -1, physicsClientId=c)] for body in bodies)
        assert a == b
        assert pb.getNumBodies(physicsClientId=c) == 2
    finally:
        pb.disconnect(physicsClientId=c)


def test_asset_cache_is_versioned_and_textures_are_reused(tmp_path: Path) -> None:
    folder = asset_cache_dir(tmp_path)
    assert folder.parent == tmp_path and folder.name.startswith("world-assets-v")
    first = ensure_dice_textures(folder)
    mtimes = {c: p.stat().st_mtime_ns for c, p in first.items()}
    second = ensure_dice_textures(folder)
    assert first == second and set(first) == set(COLOURS)
    assert {c: p.stat().st_mtime_ns for c, p in second.items()} == mtimes
    assert not list(folder.glob("*.tmp"))


def test_every_shape_rests_at_its_vocabulary_height_with_its_extents(world: Any) -> None:
    shapes = [s for s in SHAPES for _ in range(2)]
    items = [(s, "red", on_table(s, -0.3 + 0.12 * i, 0.0, yaw=0.0)) for i, s in enumerate(shapes)]
    scene = scene_of(items)
    world.begin(scene.objects)
    for i, pose in enumerate(scene.initial):
        world.place(i, pose, lift=0.001)
    assert world.settle().settled
    poses = world.poses()
    for i, shape in enumerate(shapes):
        expected = TABLE_TOP_Z + EXTENTS[shape][2] / 2
        assert poses[i, 2] == pytest.approx(expected, abs=3e-4), shape
        lo, hi = world.pb.getAABB(world.bodies[i], -1, physicsClientId=world.client)
        size = np.subtract(hi, lo)
        # PyBullet pads AABBs by a fixed contact margin; the box itself must fit exactly.
        pad = size - np.asarray(EXTENTS[shape])
        assert np.allclose(pad, pad[0], atol=2e-3) and -1e-9 <= pad[0] < 0.05, (shape, size)
