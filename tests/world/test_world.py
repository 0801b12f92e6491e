"""The World: fresh simulations per instance, renders, segmentation, the camera's framing and the robot."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

from world_scenes import grid_scene  # noqa: E402

from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.generators.world.world import RenderedImages  # noqa: E402
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA  # noqa: E402
from nsrmp_bench.vocabulary import COLOURS, EXTENTS, SHAPES, TABLE_TOP_Z, TARGET_AREA  # noqa: E402

pytestmark = pytest.mark.sim

# The workspace volume: every object centre in TARGET_AREA, widened by the largest half
# diagonal (a yawed lego) and up to a 3-high stack of the tallest objects.
_HALF_DIAG = float(np.hypot(*EXTENTS["lego"][:2]) / 2)
_WORKSPACE = np.array([
    [x, y, z]
    for x in (TARGET_AREA.x_min - _HALF_DIAG, TARGET_AREA.x_max + _HALF_DIAG)
    for y in (TARGET_AREA.y_min - _HALF_DIAG, TARGET_AREA.y_max + _HALF_DIAG)
    for z in (TABLE_TOP_Z, TABLE_TOP_Z + 3 * 0.05 + 0.005)
])


def _spread(rng: np.random.Generator, n: int) -> Any:
    shapes = [SHAPES[int(i)] for i in rng.integers(0, 3, n)]
    colours = [COLOURS[int(i)] for i in rng.integers(0, 7, n)]
    return grid_scene(shapes, colours, yaws=list(rng.uniform(0, np.pi, n)))


def test_every_instance_starts_from_a_fresh_simulation(world: Any) -> None:
    rng = np.random.default_rng(3)
    world.begin(())
    scenery = world.body_count()
    for _ in range(6):
        scene = _spread(rng, int(rng.integers(1, 16)))
        bodies = world.begin(scene.objects)
        assert world.body_count() == scenery + len(scene.objects)
        assert list(bodies) == list(range(scenery, scenery + len(scene.objects)))
        for i, pose in enumerate(scene.initial):
            world.place(i, pose, lift=0.001)
        world.step(2)


def test_more_objects_of_a_shape_than_the_v1_pool_held_are_fine(world: Any) -> None:
    scene = grid_scene(["cube"] * 16, ["red"] * 16)
    world.begin(scene.objects)
    for i, pose in enumerate(scene.initial):
        world.place(i, pose, lift=0.001)
    world.step(1)
    assert len(world.poses()) == 16


def test_render_gives_rgb_metric_depth_and_object_indices(world: Any) -> None:
    scene = _spread(np.random.default_rng(5), 7)
    world.begin(scene.objects)
    for i, pose in enumerate(scene.initial):
        world.place(i, pose, lift=0.001)
    world.settle()
    img = world.render()
    h, w = OFFICIAL_CAMERA.height, OFFICIAL_CAMERA.width
    assert img.rgb.shape == (h, w, 3) and img.rgb.dtype == np.uint8
    assert img.depth.shape == (h, w) and img.depth.dtype == np.float32
    assert img.segmentation.shape == (h, w) and img.segmentation.dtype == np.int16
    assert set(np.unique(img.segmentation)) == {-1, *range(7)}
    # Table pixels back-project onto the table plane: depth and camera agree.
    raw = world.pb.getCameraImage(w, h, OFFICIAL_CAMERA.view_matrix_gl,
                                  OFFICIAL_CAMERA.projection_matrix_gl_pixel_centred,
                                  renderer=world.pb.ER_TINY_RENDERER,
                                  physicsClientId=world.client)[4]
    rows, cols = np.nonzero(np.asarray(raw).reshape(h, w) == world.table)
    pick = np.linspace(0, rows.size - 1, 200).astype(int)
    uv = np.stack([cols[pick] + 0.5, rows[pick] + 0.5], axis=1)
    pts = OFFICIAL_CAMERA.backproject(uv, img.depth[rows[pick], cols[pick]])
    inside = (np.abs(pts[:, 0]) < 0.7) & (np.abs(pts[:, 1]) < 0.45)
    assert inside.sum() > 100
    assert np.abs(pts[inside, 2] - TABLE_TOP_Z).max() < 1e-3
    # Robot and table are background in the object-index mask.
    assert (img.segmentation[np.asarray(raw).reshape(h, w) == world.panda] == -1).all()


def test_the_camera_frames_the_whole_workspace_left_is_minus_x_behind_is_up() -> None:
    uv, z = OFFICIAL_CAMERA.project(_WORKSPACE)
    assert (z > 0).all()
    margin = 3.0
    assert uv[:, 0].min() >= margin and uv[:, 0].max() <= OFFICIAL_CAMERA.width - margin
    assert uv[:, 1].min() >= margin and uv[:, 1].max() <= OFFICIAL_CAMERA.height - margin
    # tight: the near corners come within 10 px of the left, right and bottom edges
    assert uv[:, 0].min() < 10 and uv[:, 0].max() > OFFICIAL_CAMERA.width - 10
    assert uv[:, 1].max() > OFFICIAL_CAMERA.height - 10
    (left, right, behind, front), _ = OFFICIAL_CAMERA.project(np.array([
        [-0.2, 0, TABLE_TOP_Z], [0.2, 0, TABLE_TOP_Z], [0, 0.2, TABLE_TOP_Z], [0, -0.2, TABLE_TOP_Z]]))
    assert left[0] < right[0]
    assert behind[1] < front[1]


@pytest.mark.parametrize("size", [(320, 240), (1024, 768), (256, 256), (224, 224), (480, 360),
                                  (640, 360)])
def test_official_camera_keeps_the_workspace_in_view_at_any_size(size: tuple[int, int]) -> None:
    from nsrmp_bench.geometry.default_camera import official_camera

    cam = official_camera(*size)
    uv, _ = cam.project(_WORKSPACE)
    u = uv[:, 0] / cam.width
    v = uv[:, 1] / cam.height
    assert u.min() > 0.005 and u.max() < 0.995 and v.min() > 0.005 and v.max() < 0.995
    if size[0] * 3 == size[1] * 4:
        assert cam.fov_y_deg == OFFICIAL_CAMERA.fov_y_deg


def test_the_robot_is_in_view_but_never_in_front_of_the_workspace(world: Any) -> None:
    cam = OFFICIAL_CAMERA
    world.begin(())
    raw = world.pb.getCameraImage(cam.width, cam.height, cam.view_matrix_gl,
                                  cam.projection_matrix_gl_pixel_centred,
                                  renderer=world.pb.ER_TINY_RENDERER,
                                  physicsClientId=world.client)[4]
    robot = np.asarray(raw).reshape(cam.height, cam.width) == world.panda
    uv, _ = cam.project(_WORKSPACE)
    hull = cv2.convexHull(np.round(uv * 16).astype(np.int32))
    workspace = np.zeros((cam.height, cam.width), np.uint8)
    cv2.fillConvexPoly(workspace, hull, 1, cv2.LINE_8, 4)
    assert robot.sum() > 300, "the robot should be visible above the workspace"
    assert not (robot & (workspace > 0)).any(), "the robot hides part of the workspace"
    # and physically it stands behind every object
    pb = world.pb
    ys = [pb.getAABB(world.panda, link, physicsClientId=world.client)[0][1]
          for link in range(-1, pb.getNumJoints(world.panda, physicsClientId=world.client))]
    assert min(ys) > TARGET_AREA.y_max + _HALF_DIAG


def test_composite_render_equals_the_full_render(world: Any) -> None:
    rng = np.random.default_rng(8)
    scene = _spread(rng, 12)
    world.begin(scene.objects)
    world.prepare_background()
    for i, pose in enumerate(scene.initial):
        world.place(i, pose, lift=0.001)
    world.settle()
    full = world.render()
    comp = world.render(composite=True)
    again = world.render()
    for a, b in ((full.rgb, again.rgb), (full.depth, again.depth),
                 (full.segmentation, again.segmentation)):
        assert np.array_equal(a, b), "hiding the scenery must leave no trace"
    differ = (comp.segmentation != full.segmentation)
    # only where an object's bottom edge and the table top tie in depth
    assert differ.sum() <= 3
    assert (full.segmentation[differ] == -1).all() and (comp.segmentation[differ] >= 0).all()
    same = ~differ
    assert np.array_equal(comp.rgb[same], full.rgb[same])
    assert np.array_equal(comp.depth[same], full.depth[same])
    # written into given arrays (one state's slices of an episode's), the same values
    h, w = comp.segmentation.shape
    rgb = np.zeros((2, h, w, 3), np.uint8)
    depth = np.zeros((2, h, w), np.float32)
    seg = np.zeros((2, h, w), np.int16)
    for k, composite, expected in ((0, True, comp), (1, False, full)):
        out = RenderedImages(rgb[k], depth[k], seg[k])
        assert world.render(composite=composite, out=out) is out
        for a, b in ((rgb[k], expected.rgb), (depth[k], expected.depth),
                     (seg[k], expected.segmentation)):
            assert np.array_equal(a, b)


def test_render_into_arrays_of_another_size_is_refused(world: Any) -> None:
    h, w = OFFICIAL_CAMERA.height, OFFICIAL_CAMERA.width
    wrong = RenderedImages(np.zeros((h, w + 1, 3), np.uint8), np.zeros((h, w), np.float32),
                           np.zeros((h, w), np.int16))
    with pytest.raises(InvalidArgument, match=r"out\.rgb .* shape \(.*\); expected"):
        world.render(composite=True, out=wrong)
    ints = RenderedImages(np.zeros((h, w, 3), np.uint8), np.zeros((h, w), np.float64),
                          np.zeros((h, w), np.int16))
    with pytest.raises(InvalidArgument, match=r"out\.depth is a float64"):
        world.render(out=ints)


def test_composite_render_needs_a_prepared_background(world: Any) -> None:
    cam = OFFICIAL_CAMERA.resized(64, 48)
    world.begin(())
    with pytest.raises(InvalidArgument, match="prepare_background"):
        world.render(cam, composite=True)


def test_a_world_begun_without_scenery_visuals_refuses_full_renders() -> None:
    from nsrmp_bench.generators.world.world import World

    with World() as world:
        world.begin((), scenery_visuals=False)
        assert not world.has_background()
        with pytest.raises(InvalidArgument, match="scenery_visuals=False"):
            world.render()
        with pytest.raises(InvalidArgument, match="scenery_visuals=False"):
            world.prepare_background()
        world.begin(())
        world.prepare_background()
        assert world.has_background()
        world.begin((), scenery_visuals=False)
        world.render(composite=True)  # over the cached background: fine
