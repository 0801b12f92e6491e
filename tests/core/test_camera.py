"""The camera model: projection round trip, amodal boxes, and PyBullet's matrices."""

from __future__ import annotations

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA, official_camera


def test_project_then_backproject_is_identity() -> None:
    rng = np.random.default_rng(0)
    pts = rng.uniform([-0.4, -0.3, 0.62], [0.4, 0.3, 0.8], size=(200, 3))
    uv, depth = OFFICIAL_CAMERA.project(pts)
    back = OFFICIAL_CAMERA.backproject(uv, depth)
    assert np.allclose(back, pts, atol=1e-9)


def test_image_left_is_minus_x_and_behind_is_up() -> None:
    (u_left, _), (u_right, _) = OFFICIAL_CAMERA.project(np.array([[-0.2, 0, 0.625], [0.2, 0, 0.625]]))[0]
    assert u_left < u_right
    (_, v_front), (_, v_behind) = OFFICIAL_CAMERA.project(np.array([[0, -0.2, 0.625], [0, 0.2, 0.625]]))[0]
    assert v_behind < v_front


def test_amodal_box_of_a_cube_contains_its_corners_and_rotation_matters() -> None:
    ext = np.array([[0.05, 0.05, 0.05]])
    pos = np.array([[0.0, 0.0, 0.65]])
    flat = OFFICIAL_CAMERA.amodal_boxes(ext, pos, np.array([[0, 0, 0, 1.0]]))[0]
    turned = OFFICIAL_CAMERA.amodal_boxes(ext, pos, np.array([[0, 0, 0.3826834, 0.9238795]]))[0]
    assert flat[2] > flat[0] and flat[3] > flat[1]
    assert (turned[2] - turned[0]) > (flat[2] - flat[0])  # 45 degrees: wider footprint
    centre, _ = OFFICIAL_CAMERA.project(pos)
    assert flat[0] < centre[0, 0] < flat[2] and flat[1] < centre[0, 1] < flat[3]


def test_bad_cameras_are_rejected() -> None:
    with pytest.raises(InvalidArgument, match="image size must be positive"):
        Camera(0, 240, 40.0, (0, -1, 1), (0, 0, 0))
    with pytest.raises(InvalidArgument, match="need 0 < near < far"):
        Camera(320, 240, 40.0, (0, -1, 1), (0, 0, 0), near=2.0, far=1.0)
    with pytest.raises(InvalidArgument, match=r"a camera needs width, height, fov_y_deg"):
        Camera.from_dict({"width": 3})


def test_dict_round_trip_and_resize() -> None:
    assert Camera.from_dict(OFFICIAL_CAMERA.to_dict()) == OFFICIAL_CAMERA
    big = official_camera(1024, 768)
    assert big.intrinsics[0, 2] == 512 and big.intrinsics[1, 2] == 384


@pytest.mark.sim
def test_gl_matrices_equal_pybullets() -> None:
    pb = pytest.importorskip("pybullet")
    c = OFFICIAL_CAMERA
    view = pb.computeViewMatrix(c.eye, c.target, c.up)
    proj = pb.computeProjectionMatrixFOV(c.fov_y_deg, c.width / c.height, c.near, c.far)
    assert np.allclose(view, c.view_matrix_gl, atol=1e-6)
    assert np.allclose(proj, c.projection_matrix_gl, atol=1e-6)
    shifted = np.array(c.projection_matrix_gl_pixel_centred) - np.array(c.projection_matrix_gl)
    assert np.count_nonzero(np.abs(shifted) > 1e-9) == 2


def test_linearize_depth_gives_the_formulas_bits_and_leaves_its_input() -> None:
    """In place, it is still ``f * n / (f - (f - n) * d)`` in float64 rounded to float32,
    bit for bit (stored depth images depend on it), over the whole z-buffer range."""
    rng = np.random.default_rng(7)
    zbuf = np.concatenate([rng.random(100_000, dtype=np.float32),
                           np.float32([0.0, 1.0, 0.5, 0.999999])]).reshape(-1, 4)
    before = zbuf.copy()
    cam = OFFICIAL_CAMERA
    n, f = cam.near, cam.far
    expected = (f * n / (f - (f - n) * zbuf.astype(np.float64))).astype(np.float32)
    got = cam.linearize_depth(zbuf)
    assert got.dtype == np.float32 and got.shape == zbuf.shape
    assert got.tobytes() == expected.tobytes()
    assert zbuf.tobytes() == before.tobytes()
    as_float64 = zbuf.astype(np.float64)  # a float64 z-buffer is not worked on either
    cam.linearize_depth(as_float64)
    assert as_float64.tobytes() == zbuf.astype(np.float64).tobytes()
