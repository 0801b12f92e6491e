"""A pinhole camera: intrinsics, extrinsics, projection and back-projection.

Conventions: the camera's optical frame has +x to image-right, +y image-down and +z
along the viewing direction (OpenCV). Pixel coordinates are continuous, with (0, 0) the
top-left corner of the top-left pixel, so pixel (i, j) has its centre at (j + 0.5, i + 0.5).
Depth is the distance along the optical axis, in metres. The OpenGL matrices that PyBullet
renders with are derived from the same numbers, so projected boxes match rendered pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument

__all__ = ["Camera", "quaternion_matrices"]

F64 = NDArray[np.float64]


def _frozen(a: F64) -> F64:
    a.setflags(write=False)
    return a


def _unit(v: F64) -> F64:
    n = float(np.linalg.norm(v))
    if n == 0.0:
        msg = "camera eye, target and up must not be degenerate (zero-length direction)"
        raise InvalidArgument(msg)
    return v / n


@dataclass(frozen=True)
class Camera:
    """A fixed pinhole camera looking from ``eye`` at ``target``."""

    width: int
    height: int
    fov_y_deg: float
    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    near: float = 0.05
    far: float = 4.0

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            msg = f"image size must be positive, got {self.width}x{self.height}"
            raise InvalidArgument(msg)
        if not 0.0 < self.fov_y_deg < 180.0:
            msg = f"fov_y_deg must be in (0, 180), got {self.fov_y_deg}"
            raise InvalidArgument(msg)
        if not 0.0 < self.near < self.far:
            msg = f"need 0 < near < far, got near={self.near}, far={self.far}"
            raise InvalidArgument(msg)

    # -- intrinsics and extrinsics -------------------------------------------------
    @property
    def focal(self) -> float:
        """Focal length in pixels (square pixels)."""
        return (self.height / 2.0) / math.tan(math.radians(self.fov_y_deg) / 2.0)

    @property
    def intrinsics(self) -> F64:
        """The 3x3 matrix K."""
        f = self.focal
        return np.array(
            [[f, 0.0, self.width / 2.0], [0.0, f, self.height / 2.0], [0.0, 0.0, 1.0]]
        )

    @cached_property
    def rotation(self) -> F64:
        """3x3 rotation taking world directions into the optical frame (read-only)."""
        eye = np.asarray(self.eye, dtype=np.float64)
        fwd = _unit(np.asarray(self.target, dtype=np.float64) - eye)
        right = _unit(np.cross(fwd, np.asarray(self.up, dtype=np.float64)))
        down = np.cross(fwd, right)
        return _frozen(np.stack([right, down, fwd]))

    @cached_property
    def extrinsics(self) -> F64:
        """4x4 transform from world to the optical frame (read-only)."""
        r = self.rotation
        t = -r @ np.asarray(self.eye, dtype=np.float64)
        out = np.eye(4)
        out[:3, :3] = r
        out[:3, 3] = t
        return _frozen(out)

    @property
    def view_matrix_gl(self) -> list[float]:
        """OpenGL view matrix, column-major (what PyBullet's computeViewMatrix returns)."""
        flip = np.diag([1.0, -1.0, -1.0, 1.0])  # optical frame -> OpenGL eye frame
        return [float(v) for v in (flip @ self.extrinsics).T.reshape(-1)]

    @property
    def projection_matrix_gl(self) -> list[float]:
        """OpenGL perspective matrix, column-major (PyBullet's computeProjectionMatrixFOV)."""
        aspect = self.width / self.height
        t = 1.0 / math.tan(math.radians(self.fov_y_deg) / 2.0)
        n, f = self.near, self.far
        m = np.zeros((4, 4))
        m[0, 0] = t / aspect
        m[1, 1] = t
        m[2, 2] = (f + n) / (n - f)
        m[2, 3] = 2.0 * f * n / (n - f)
        m[3, 2] = -1.0
        return [float(v) for v in m.T.reshape(-1)]

    @property
    def projection_matrix_gl_pixel_centred(self) -> list[float]:
        """The projection to render with, so rendered pixels follow this camera's convention.

        TinyRenderer samples pixel (i, j) at the integer coordinates of OpenGL's bottom-up
        window, i.e. at ``(j, i + 1)`` in this camera's top-down pixel frame; with
        :attr:`projection_matrix_gl` as is, objects come out half a pixel right of and above
        their projection (mask against projected silhouette IoU 0.91; 1.00 with this
        shift). The shift is -0.5 px in x and +0.5 px in y.
        """
        m = self.projection_matrix_gl  # column-major: element (r, c) at c * 4 + r
        m[2 * 4 + 0] += 1.0 / self.width  # x_clip += (-1/W) * w_clip, w_clip = -z_eye
        m[2 * 4 + 1] += 1.0 / self.height  # y_clip += (-1/H) * w_clip
        return m

    def linearize_depth(self, zbuffer: NDArray[Any]) -> NDArray[np.float32]:
        """Turn an OpenGL z-buffer in [0, 1] into optical-axis depth in metres:
        ``f * n / (f - (f - n) * d)`` in float64, rounded to float32, computed in place
        (negating a product and adding it are exact, so the bits are the formula's)."""
        d = np.array(zbuffer, dtype=np.float64)  # a copy: worked on in place
        n, f = self.near, self.far
        d *= -(f - n)
        d += f
        np.divide(f * n, d, out=d)
        return d.astype(np.float32)

    # -- projection ------------------------------------------------------------------
    @cached_property
    def projection(self) -> F64:
        """The 3x4 matrix K[R|t] (computed once per camera; read-only)."""
        return _frozen(self.intrinsics @ self.extrinsics[:3, :])

    def project(self, points: NDArray[Any]) -> tuple[F64, F64]:
        """Project world points ``(..., 3)`` to pixels ``(..., 2)`` and depths ``(...)``."""
        p = self.projection
        rt = self.extrinsics
        pts = np.asarray(points, dtype=np.float64)
        h = pts @ p[:, :3].T + p[:, 3]
        z = pts @ rt[2, :3] + rt[2, 3]
        return h[..., :2] / h[..., 2:3], z

    def backproject(self, pixels: NDArray[Any], depth: NDArray[Any]) -> F64:
        """Inverse of :meth:`project`: pixels ``(..., 2)`` at depths ``(...)`` to world points."""
        uv = np.asarray(pixels, dtype=np.float64)
        z = np.asarray(depth, dtype=np.float64)
        f = self.focal
        x = (uv[..., 0] - self.width / 2.0) / f * z
        y = (uv[..., 1] - self.height / 2.0) / f * z
        cam = np.stack([x, y, z], axis=-1)
        return cam @ self.rotation + np.asarray(self.eye, dtype=np.float64)

    def ray_at_height(self, pixel: NDArray[Any] | tuple[float, float], z: float) -> F64 | None:
        """Where the ray through ``pixel`` meets the horizontal plane at height ``z`` (world
        metres); None when it never does in front of the camera."""
        eye = np.asarray(self.eye, dtype=np.float64)
        d = self.backproject(np.asarray(pixel, dtype=np.float64), np.asarray(1.0)) - eye
        if abs(d[2]) < 1e-12:
            return None
        t = (z - eye[2]) / d[2]
        if t <= 0.0:
            return None
        out: F64 = eye + t * d
        return out

    def amodal_boxes(
        self,
        extents: NDArray[Any],
        positions: NDArray[Any],
        orientations: NDArray[Any],
        *,
        rotations: NDArray[Any] | None = None,
    ) -> NDArray[np.float32]:
        """Amodal 2D boxes ``(N, 4)`` pixel xyxy of oriented 3D boxes, clipped to the image.

        ``extents`` are full box sizes ``(N, 3)``, ``positions`` box centres ``(N, 3)`` and
        ``orientations`` xyzw quaternions ``(N, 4)``; ``rotations`` may pass their rotation
        matrices ``(N, 3, 3)`` when the caller has them already.
        """
        ext = np.asarray(extents, dtype=np.float64).reshape(-1, 3)
        pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        rot = (
            quaternion_matrices(np.asarray(orientations, dtype=np.float64).reshape(-1, 4))
            if rotations is None else np.asarray(rotations, dtype=np.float64)
        )
        local = _CORNER_SIGNS[None, :, :] * ext[:, None, :]  # (N, 8, 3)
        corners = np.einsum("nij,nkj->nki", rot, local) + pos[:, None, :]
        uv, _ = self.project(corners)
        lo = uv.min(axis=1)
        hi = uv.max(axis=1)
        boxes = np.concatenate([lo, hi], axis=1)
        boxes[:, [0, 2]] = boxes[:, [0, 2]].clip(0.0, self.width)
        boxes[:, [1, 3]] = boxes[:, [1, 3]].clip(0.0, self.height)
        return boxes.astype(np.float32)

    # -- data ------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-able form, with the derived intrinsics and extrinsics for outside readers."""
        return {
            "width": self.width,
            "height": self.height,
            "fov_y_deg": self.fov_y_deg,
            "eye": list(self.eye),
            "target": list(self.target),
            "up": list(self.up),
            "near": self.near,
            "far": self.far,
            "intrinsics": self.intrinsics.tolist(),
            "extrinsics_world_to_camera": self.extrinsics.tolist(),
            "convention": "optical frame x right, y down, z forward; pixel (0,0) = top-left corner",
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Camera:
        """Inverse of :meth:`to_dict` (derived fields are ignored)."""
        try:
            return cls(
                width=int(data["width"]),
                height=int(data["height"]),
                fov_y_deg=float(data["fov_y_deg"]),
                eye=tuple(float(v) for v in data["eye"]),  # type: ignore[arg-type]
                target=tuple(float(v) for v in data["target"]),  # type: ignore[arg-type]
                up=tuple(float(v) for v in data.get("up", (0.0, 0.0, 1.0))),  # type: ignore[arg-type]
                near=float(data.get("near", 0.05)),
                far=float(data.get("far", 4.0)),
            )
        except (KeyError, TypeError, ValueError) as exc:
            msg = f"a camera needs width, height, fov_y_deg, eye and target; got {data!r}"
            raise InvalidArgument(msg) from exc

    def resized(self, width: int, height: int) -> Camera:
        """The same camera at another image size (same vertical field of view)."""
        return Camera(width, height, self.fov_y_deg, self.eye, self.target, self.up,
                      self.near, self.far)


_CORNER_SIGNS = np.array(
    [[sx, sy, sz] for sx in (-0.5, 0.5) for sy in (-0.5, 0.5) for sz in (-0.5, 0.5)]
)


def quaternion_matrices(q: NDArray[Any]) -> F64:
    """Rotation matrices ``(N, 3, 3)`` of xyzw quaternions ``(N, 4)`` (normalised first)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )
