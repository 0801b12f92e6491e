"""Procedural assets of the world, made by our code: no asset file is copied.

* **cube**: a 5 cm box in one of the 7 colours.
* **dice**: a 5 cm box mesh whose six faces carry 1..6 pips (opposite faces sum to 7),
  textured from a pip atlas drawn with numpy/cv2 (one texture per colour, written to the
  asset cache).
* **lego**: a 2x2 brick, a box body plus four cylindrical studs, whose bounding box is
  exactly ``EXTENTS["lego"]``; collision is the same compound (box + cylinders).

Every body's frame is the centre of its bounding box, so a symbolic pose (box centre) is
the body pose. The table and the Franka Panda come from ``pybullet_data``; the "lean"
Panda is a variant URDF, generated at runtime from pybullet_data's own text, whose
visuals are its collision meshes (3.5k instead of 103k triangles; see
``shared/reference/perf-limits.md`` §2.2).
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import tempfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.vocabulary import COLOUR_RGBA, COLOURS, EXTENTS

__all__ = [
    "ASSET_VERSION",
    "DICE_FACE_PIPS",
    "LEGO_STUD_HEIGHT",
    "LEGO_STUD_PITCH",
    "LEGO_STUD_RADIUS",
    "OBJECT_DYNAMICS",
    "ShapeIds",
    "asset_cache_dir",
    "collision_obj",
    "create_shape_ids",
    "dice_mesh",
    "dice_texture",
    "ensure_dice_textures",
    "lean_panda_urdf",
    "lego_parts",
    "silhouette_points",
    "write_atomically",
]

ASSET_VERSION: Final = "world-assets-v1"
"""Version of the procedural assets; part of the cache folder name."""

OBJECT_DYNAMICS: Final[dict[str, float]] = {
    "mass": 0.1,
    "lateralFriction": 1.0,
    "spinningFriction": 0.001,
    "rollingFriction": 0.0,
    "restitution": 0.0,
    "linearDamping": 0.04,
    "angularDamping": 0.04,
}
"""Dynamics of every object (kg, friction coefficients); the original used 0.1 kg, 1.0."""

# Faces in (normal axis, sign) order +x, -x, +y, -y, +z, -z; opposite faces sum to 7.
DICE_FACE_PIPS: Final[tuple[int, ...]] = (2, 5, 3, 4, 1, 6)

LEGO_STUD_RADIUS: Final = 0.0096
LEGO_STUD_HEIGHT: Final = 0.008
LEGO_STUD_PITCH: Final = 0.032
"""Stud centres lie at (+-pitch/2, +-pitch/2) on the top of the body."""

_DICE_FACE_PX: Final = 64
_LIGHT_COLOURS: Final = frozenset({"white", "yellow", "cyan"})


def asset_cache_dir(root: str | os.PathLike[str] | None = None) -> Path:
    """The folder that holds generated asset files, created if missing.

    ``root`` overrides the default ``$NSRMP_BENCH_CACHE`` or ``$XDG_CACHE_HOME/nsrmp-bench``
    (``~/.cache/nsrmp-bench``). Files are named by their content's hash and written
    atomically, so processes may share the folder.
    """
    if root is None:
        env = os.environ.get("NSRMP_BENCH_CACHE")
        if env:
            base = Path(env)
        else:
            xdg = os.environ.get("XDG_CACHE_HOME")
            base = (Path(xdg) if xdg else Path.home() / ".cache") / "nsrmp-bench"
    else:
        base = Path(root)
    out = base / ASSET_VERSION
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_atomically(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` unless it already exists (temp file + rename)."""
    if path.exists():
        return path
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_content_named(directory: Path, stem: str, suffix: str, data: bytes) -> Path:
    """``data`` written into ``directory`` as ``<stem>_<its sha256, 16 hex><suffix>``
    (:func:`write_atomically`: kept if already there)."""
    digest = hashlib.sha256(data).hexdigest()[:16]
    return write_atomically(directory / f"{stem}_{digest}{suffix}", data)


# -- dice ------------------------------------------------------------------------------
_PIP_LAYOUT: Final[dict[int, tuple[tuple[float, float], ...]]] = {
    1: ((0.5, 0.5),),
    2: ((0.27, 0.27), (0.73, 0.73)),
    3: ((0.27, 0.27), (0.5, 0.5), (0.73, 0.73)),
    4: ((0.27, 0.27), (0.73, 0.27), (0.27, 0.73), (0.73, 0.73)),
    5: ((0.27, 0.27), (0.73, 0.27), (0.5, 0.5), (0.27, 0.73), (0.73, 0.73)),
    6: ((0.27, 0.25), (0.73, 0.25), (0.27, 0.5), (0.73, 0.5), (0.27, 0.75), (0.73, 0.75)),
}


def dice_texture(colour: str, face_px: int = _DICE_FACE_PX) -> NDArray[np.uint8]:
    """The RGB pip atlas ``(face_px, 6 * face_px, 3)`` of a dice: one square per face.

    Cell ``k`` (left to right) is face ``k`` of :data:`DICE_FACE_PIPS`. Light colours get
    black pips, the others white pips.
    """
    cv2 = require("cv2")
    body = np.array([round(255 * c) for c in COLOUR_RGBA[colour][:3]], dtype=np.uint8)
    pip = (20, 20, 20) if colour in _LIGHT_COLOURS else (250, 250, 250)
    img = np.empty((face_px, 6 * face_px, 3), dtype=np.uint8)
    img[:] = body
    shift = 4
    scale = 1 << shift
    radius = round(0.095 * face_px * scale)
    for k, pips in enumerate(DICE_FACE_PIPS):
        for u, v in _PIP_LAYOUT[pips]:
            centre = (round((k + u) * face_px * scale), round(v * face_px * scale))
            cv2.circle(img, centre, radius, pip, -1, cv2.LINE_AA, shift)
    out: NDArray[np.uint8] = img
    return out


def ensure_dice_textures(directory: Path) -> dict[str, Path]:
    """Write the 7 dice textures (PNG) into ``directory`` if missing; colour -> path."""
    cv2 = require("cv2")
    paths: dict[str, Path] = {}
    for colour in COLOURS:
        rgb = dice_texture(colour)
        ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
        if not ok:  # pragma: no cover - cv2 always encodes uint8 PNGs
            msg = f"could not encode the {colour} dice texture as PNG"
            raise RuntimeError(msg)
        paths[colour] = write_content_named(directory, f"dice_{colour}", ".png", bytes(buf))
    return paths


@lru_cache(maxsize=8)
def dice_mesh(size: float) -> dict[str, list[Any]]:
    """Vertices, indices, uvs and normals of a cube of edge ``size`` with an atlas UV map
    (made once per size and shared: read it, do not change it).

    Face ``k`` (order of :data:`DICE_FACE_PIPS`) maps to atlas cell ``k`` of a one-row
    atlas, so the map does not depend on whether the renderer flips ``v``.
    """
    h = size / 2.0
    eps = 0.5 / (6 * _DICE_FACE_PX)  # half a texel inset against bleeding between cells
    vertices: list[list[float]] = []
    uvs: list[list[float]] = []
    normals: list[list[float]] = []
    indices: list[int] = []
    for k, (axis, sign) in enumerate(((0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1))):
        n = [0.0, 0.0, 0.0]
        n[axis] = float(sign)
        # two tangent axes with t1 x t2 = n (counter-clockwise seen from outside)
        t1 = [0.0, 0.0, 0.0]
        t2 = [0.0, 0.0, 0.0]
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        t1[a1] = 1.0
        t2[a2] = float(sign)
        base = len(vertices)
        for s1, s2 in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            vertices.append([h * (n[i] + s1 * t1[i] + s2 * t2[i]) for i in range(3)])
            u = (k + (0.5 + 0.5 * s1)) / 6.0
            u = min(max(u, k / 6.0 + eps), (k + 1) / 6.0 - eps)
            v = min(max(0.5 + 0.5 * s2, eps * 6), 1.0 - eps * 6)
            uvs.append([u, v])
            normals.append(list(n))
        indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    return {"vertices": vertices, "indices": indices, "uvs": uvs, "normals": normals}


# -- lego ------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Part:
    kind: str  # "box" | "cylinder"
    half_extents: tuple[float, float, float]  # box: half sizes; cylinder: (r, r, h/2)
    position: tuple[float, float, float]


@lru_cache(maxsize=1)
def lego_parts() -> tuple[_Part, ...]:
    """The brick's convex parts in its box-centred frame: the body, then the four studs
    (immutable, made once)."""
    ex, ey, ez = EXTENTS["lego"]
    body_h = ez - LEGO_STUD_HEIGHT
    z_body = -ez / 2.0 + body_h / 2.0
    z_stud = ez / 2.0 - LEGO_STUD_HEIGHT / 2.0
    q = LEGO_STUD_PITCH / 2.0
    parts = [_Part("box", (ex / 2.0, ey / 2.0, body_h / 2.0), (0.0, 0.0, z_body))]
    r = LEGO_STUD_RADIUS
    for sx, sy in ((-1, -1), (1, -1), (-1, 1), (1, 1)):
        parts.append(_Part("cylinder", (r, r, LEGO_STUD_HEIGHT / 2.0), (sx * q, sy * q, z_stud)))
    return tuple(parts)


def silhouette_points(shape: str, circle_points: int = 16) -> NDArray[np.float64]:
    """Points in the object frame whose projected convex hull is the object's silhouette.

    Exact for cube and dice (the 8 corners); for the lego, the body's corners and points on
    the studs' top and bottom circles (the hull slightly overestimates the true outline,
    which has notches between studs).
    """
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                     dtype=np.float64)
    if shape != "lego":
        return signs * (np.asarray(EXTENTS[shape], dtype=np.float64) / 2.0)
    pts: list[NDArray[np.float64]] = []
    for part in lego_parts():
        c = np.asarray(part.position, dtype=np.float64)
        if part.kind == "box":
            pts.append(signs * np.asarray(part.half_extents) + c)
        else:
            a = np.linspace(0.0, 2.0 * np.pi, circle_points, endpoint=False).tolist()
            r, _, hz = part.half_extents
            # math.cos/sin (libm), not np.cos/np.sin: numpy's SIMD kernels differ by CPU.
            ring = np.array([[r * math.cos(t), r * math.sin(t), 0.0] for t in a],
                            dtype=np.float64).reshape(-1, 3)
            pts.append(ring + c + [0.0, 0.0, hz])
            pts.append(ring + c - [0.0, 0.0, hz])
    return np.concatenate(pts, axis=0)


# -- PyBullet shapes -------------------------------------------------------------------
@dataclass(frozen=True)
class ShapeIds:
    """Collision and visual shape ids of one shape in one client (created once, reused)."""

    collision: int
    visual: int


def create_shape_ids(pb: ModuleType, client: int, shape: str, *, visual: bool = True) -> ShapeIds:
    """Create the collision and visual shapes of ``shape`` (colour is set per body);
    ``visual=False``: the collision shape only (``visual`` -1), for bodies made without a
    visual shape (the physics-only client's)."""
    white = [1.0, 1.0, 1.0, 1.0]
    vis = -1
    if shape == "cube":
        half = [e / 2.0 for e in EXTENTS["cube"]]
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
        if visual:
            vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=white,
                                       physicsClientId=client)
    elif shape == "dice":
        half = [e / 2.0 for e in EXTENTS["dice"]]
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
        if visual:
            mesh = dice_mesh(EXTENTS["dice"][0])
            vis = pb.createVisualShape(pb.GEOM_MESH, rgbaColor=white,
                                       physicsClientId=client, **mesh)
    elif shape == "lego":
        parts = lego_parts()
        kinds = [pb.GEOM_BOX if p.kind == "box" else pb.GEOM_CYLINDER for p in parts]
        half_extents = [list(p.half_extents) if p.kind == "box" else [0.0, 0.0, 0.0]
                        for p in parts]
        radii = [p.half_extents[0] if p.kind == "cylinder" else 0.0 for p in parts]
        lengths = [2.0 * p.half_extents[2] if p.kind == "cylinder" else 0.0 for p in parts]
        positions = [list(p.position) for p in parts]
        col = pb.createCollisionShapeArray(
            shapeTypes=kinds, halfExtents=half_extents, radii=radii, lengths=lengths,
            collisionFramePositions=positions, physicsClientId=client)
        if visual:
            vis = pb.createVisualShapeArray(
                shapeTypes=kinds, halfExtents=half_extents, radii=radii, lengths=lengths,
                visualFramePositions=positions, rgbaColors=[white] * len(parts),
                physicsClientId=client)
    else:
        msg = f"unknown shape {shape!r}; expected one of cube, dice, lego"
        raise ValueError(msg)
    if col < 0 or (visual and vis < 0):
        msg = f"PyBullet could not create the {shape} shapes (collision {col}, visual {vis})"
        raise RuntimeError(msg)
    return ShapeIds(int(col), int(vis))


# -- the lean Panda --------------------------------------------------------------------
def collision_obj(src: Path, directory: Path) -> Path:
    """The part of the Wavefront file ``src`` that Bullet's collision import reads, written
    into ``directory`` (named by its content's hash).

    A ``<collision>`` mesh becomes one convex hull per ``o``/``g`` group, built from the
    ``v`` positions its faces index, face by face; normals, texture coordinates and
    materials are read and thrown away. The copy keeps every ``v``, ``o`` and ``g`` line
    verbatim and every face with its position indices only, so the hulls get the same
    points in the same order (the same shapes, bit for bit: ``tests/world``) from a file
    that parses in about half the time.
    """
    out: list[str] = []
    for line in src.read_text("utf-8").splitlines():
        token = line.lstrip(" \t")
        head = token[:2]
        if head in ("v ", "v\t", "o ", "o\t", "g ", "g\t"):
            out.append(token)
        elif head in ("f ", "f\t"):
            out.append("f " + " ".join(t.split("/", 1)[0] for t in token[2:].split()))
    data = ("\n".join(out) + "\n").encode("utf-8")
    return write_content_named(directory, f"{src.stem}_collision", ".obj", data)


_STAND_IN_VISUAL: Final = '<visual><geometry><box size="0.001 0.001 0.001"/></geometry></visual>'
_VISUAL_ELEMENT: Final = re.compile(r"<visual>.*?</visual>", re.DOTALL)


def bounding_points_obj(src: Path, directory: Path) -> Path:
    """The six points that bound each of ``src``'s collision hulls, as a Wavefront file
    written into ``directory`` (named by its content's hash).

    For each ``o``/``g`` group, of the positions its faces index (the points Bullet's
    collision import builds the group's hull from, :func:`collision_obj`), the first that
    is lowest and the first that is highest along x, y and z, in the order they come;
    faces are consecutive triples of them. Bullet's hull of these points has the same
    bounding box as the whole mesh's, to the bit (the box is read off these same extreme
    coordinates), in a twentieth of the time: what a resting arm that nothing touches is
    to the broadphase (:meth:`World.begin`'s ``robot_collision``).
    """
    positions: list[str] = []
    groups: list[tuple[str, list[int]]] = []
    for line in src.read_text("utf-8").splitlines():
        token = line.lstrip(" \t")
        head = token[:2]
        if head in ("v ", "v\t"):
            positions.append(token)
        elif head in ("o ", "o\t", "g ", "g\t"):
            groups.append((token, []))
        elif head in ("f ", "f\t"):
            if not groups:
                groups.append(("o hull", []))
            groups[-1][1].extend(int(t.split("/", 1)[0]) for t in token[2:].split())
    out: list[str] = []
    count = 0
    for name, used in groups:
        if not used:
            continue
        refs = [i if i > 0 else len(positions) + 1 + i for i in used]
        coords = [[float(v) for v in positions[i - 1].split()[1:4]] for i in refs]
        keep: set[int] = set()
        for axis in range(3):
            values = [c[axis] for c in coords]
            keep.add(values.index(min(values)))
            keep.add(values.index(max(values)))
        chosen = [positions[refs[k] - 1] for k in sorted(keep)]
        first = count + 1
        count += len(chosen)
        idx = list(range(first, count + 1))
        idx += [count] * (-len(idx) % 3)
        out += [name, *chosen]
        out += [f"f {idx[k]} {idx[k + 1]} {idx[k + 2]}" for k in range(0, len(idx), 3)]
    data = ("\n".join(out) + "\n").encode("utf-8")
    return write_content_named(directory, f"{src.stem}_bounds", ".obj", data)


def _without_visuals(text: str) -> str:
    """URDF ``text`` with no ``<visual>`` element, comment or indentation: what a load in
    a client without a renderer builds from (the same links, joints, inertias, contact
    parameters and collision shapes; the XML parse only has less to read).

    One element per line, not one line: PyBullet reads a URDF line by line and breaks a
    line after 8,191 characters, mid-attribute (the arm's file holds the asset cache's
    absolute paths, so its length depends on where the cache is)."""
    text = _VISUAL_ELEMENT.sub("", text)
    text = re.sub(r"<!--.*?-->", "", text, flags=re.DOTALL)
    return re.sub(r">\s+<", ">\n<", text).strip() + "\n"


def physics_urdf(src: Path, directory: Path) -> Path:
    """The URDF ``src`` without its visuals (:func:`_without_visuals`), written into
    ``directory`` as ``<its stem>_physics_<hash>.urdf``: the same body for a load that
    draws nothing. For pybullet_data's table (loaded with ``URDF_IGNORE_VISUAL_SHAPES``,
    which parses its five visuals and then drops them) and for :func:`lean_panda_urdf`'s
    arm in a client without a renderer (``object_twin.physics_only_client``), where its
    stand-in visuals would still be made into meshes. ``tests/world`` compares the loads."""
    if not src.is_file():
        msg = (f"no URDF at {src}; pybullet_data's files come with pybullet (reinstall "
               "it), the asset cache's are made again by World()")
        raise FileNotFoundError(msg)
    data = _without_visuals(src.read_text("utf-8")).encode("utf-8")
    return write_content_named(directory, f"{src.stem}_physics", ".urdf", data)


def lean_panda_urdf(directory: Path, data_path: str | os.PathLike[str], *,
                    lean_collision: bool = True, visuals: bool = True,
                    bounds: bool = False) -> Path:
    """A Panda URDF whose visuals are its collision meshes, written into ``directory``.

    It is pybullet_data's ``franka_panda/panda.urdf`` with every ``package://meshes/...``
    reference made absolute and ``visual/`` meshes replaced by ``collision/`` ones: the
    kinematics, inertias and collision geometry are unchanged. ``lean_collision`` points
    the ``<collision>`` elements at :func:`collision_obj` copies of those meshes (the same
    hulls, loaded faster). ``visuals=False`` gives every ``<visual>`` a 1 mm box instead
    (for a world that never draws the arm: PyBullet would otherwise tessellate the
    collision hulls into stand-in visuals, ~1/4 of the arm's load); nothing physical
    changes, ``tests/world/test_determinism.py`` compares the shapes and dynamics.
    ``bounds=True`` points the ``<collision>`` elements at :func:`bounding_points_obj`
    copies instead: hulls with the same bounding boxes, for an arm nothing touches.
    :func:`physics_urdf` of the file leaves the visuals out altogether.
    """
    src = Path(data_path) / "franka_panda" / "panda.urdf"
    if not src.is_file():
        msg = f"pybullet_data has no Franka Panda at {src}; reinstall pybullet"
        raise FileNotFoundError(msg)
    text = src.read_text("utf-8")
    mesh_dir = (Path(data_path) / "franka_panda" / "meshes" / "collision").resolve()
    if lean_collision or bounds:
        copy = bounding_points_obj if bounds else collision_obj

        def lean(block: re.Match[str]) -> str:
            return re.sub(r'package://meshes/collision/([^"]+)',
                          lambda m: str(copy(mesh_dir / m.group(1), directory)),
                          block.group(0))

        text = re.sub(r"<collision>.*?</collision>", lean, text, flags=re.DOTALL)
    if not visuals:
        text = _VISUAL_ELEMENT.sub(_STAND_IN_VISUAL, text)
    text = text.replace("package://meshes/visual/", f"{mesh_dir}/")
    text = text.replace("package://meshes/collision/", f"{mesh_dir}/")
    return write_content_named(directory, "panda_lean", ".urdf", text.encode("utf-8"))
