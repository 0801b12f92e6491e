"""Import of the original NSRM release layout into nsrmp-bench shards.

The original layout (``dair-iitd/nsrmp``; see ``reference/nsrm-original-datagen.md``
sections 1.10 and 5) is one folder per example holding ``demo.json`` and the scene folders
``S00`` (initial) and ``S01`` (final), each with ``rgba.png`` (RGBA8), ``depth.png``
(8-bit, ``saturate(|2550 (d - 0.9)|)`` of the OpenGL depth ``d``) and ``mask.png``
(PyBullet body ids; objects are ``3 + index``, everything else 0).

What the import does:

* Programs: CLEVR-style nodes (``scene``, ``filter_type``, ``filter_color``, ``relate``,
  ``unique``, ``move``, ``idle``) become DSL nodes (``scene``, ``filter(concept)``,
  ``relate(relation)``, ``unique``, ``move[action](chain, subject, reference)``, ``idle``).
  Type and colour names are lower-cased (Cube -> cube, White -> white), actions too
  (TOP -> top). A ``relate`` fed by a set gets a ``unique`` inserted before it (the
  original requires that set to have one element). ``union``/``intersect`` and the
  ``above``/``below`` relations have no DSL equivalent and are refused.
* States: ``object_positions`` (nominal centres, as the original recorded them) with
  the objects' stored rotation. The scene carries the original's workspace
  (:data:`ORIGINAL_WORKSPACE`, its whole table top), so the step checks judge an imported
  program where it was made, not by our smaller target area.
* Images, when the scene folders exist: state 0 from ``S00``, state S from the last scene
  folder. The original renders no intermediate states: for a 2-step example the image of
  state 1 is all zero (depth NaN, segmentation -1), and ``physics["images_present"]``
  says which states have real images.
* Camera: the original renders 90 degree vertical FOV, near 0.01, far 1000, from one of
  two presets (``small_table_view`` for the shipped example, ``big_table_view_2`` in the
  code). ``camera="auto"`` picks, per example, the preset whose projected object boxes
  best match the mask.
* Targets: amodal boxes are projected from the nominal positions with the original
  objects' true sizes (cube/dice 5 cm, lego 0.0672 x 0.0672 x 0.0483 m); visible boxes
  come from the masks (NaN for states without an image); the visible fraction is unknown
  (NaN); the centre depth is projected.
* Examples without ``demo.json`` (the original writes image folders before it can fail)
  are skipped and reported. Examples without scene folders are imported symbolic-only.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.episode import (
    Episode,
    Instruction,
    ObjectTargets,
    Observations,
    ReferenceLabel,
    Rendering,
    SeedInfo,
    SymbolicEpisode,
)
from nsrmp_bench.errors import BadProgram, InvalidArgument, NSRMPError
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import Pose, Scene, SceneObject
from nsrmp_bench.storage.manifest import Manifest
from nsrmp_bench.storage.reader import open as open_collection
from nsrmp_bench.storage.resume import write_dataset
from nsrmp_bench.vocabulary import Area

__all__ = [
    "GENERATOR_ID",
    "NSRM_CAMERAS",
    "ORIGINAL_EXTENTS",
    "ORIGINAL_WORKSPACE",
    "ImportReport",
    "convert_program",
    "find_examples",
    "import_nsrm",
    "load_example",
    "symbolic_from_demo",
]

GENERATOR_ID: Final = "nsrm-original-import-v1"

_NEAR, _FAR = 0.01, 1000.0


def _preset(distance: float, pitch_deg: float, target: tuple[float, float, float]) -> Camera:
    """The original's debug-visualiser camera preset (yaw 0) as a pinhole camera."""
    p = math.radians(pitch_deg)
    eye = (target[0], target[1] - distance * math.cos(p), target[2] - distance * math.sin(p))
    return Camera(1024, 768, 90.0, eye, target, (0.0, 0.0, 1.0), _NEAR, _FAR)


NSRM_CAMERAS: Final[dict[str, Camera]] = {
    "small_table_view": _preset(12.4, -47.0, (0.0, 8.0, -8.0)),
    "big_table_view_2": _preset(12.3, -46.0, (0.0, 8.0, -7.5)),
}
"""The two camera presets the original data was rendered with, at 1024x768."""

ORIGINAL_EXTENTS: Final[dict[str, tuple[float, float, float]]] = {
    "cube": (0.05, 0.05, 0.05),
    "dice": (0.05, 0.05, 0.05),
    "lego": (0.0672, 0.0672, 0.0483),
}
"""Collision-box sizes of the original's objects (measured in PyBullet 3.2.7)."""

ORIGINAL_WORKSPACE: Final = Area("nsrm-original-table", -0.75, 0.75, -0.50, 0.50)
"""Where the original lets a moved object's centre land: anywhere on its table top
(pybullet_data's ``table.urdf``, 1.5 m x 1.0 m, centred on the origin). The original spawns
objects over a larger area than ours and never clamps targets
(``reference/nsrm-original-datagen.md`` section 2.3), so its moves near the edges leave our
:data:`~nsrmp_bench.vocabulary.TARGET_AREA`; imported scenes carry this workspace instead."""

_MASK_OFFSET: Final = 3
_SET_OPS: Final = {"scene", "filter", "relate"}


# -- programs -----------------------------------------------------------------------------
def convert_program(nodes: list[dict[str, Any]], where: str) -> Program:
    """Map the original's node list to a type-checked DSL :class:`Program`."""
    out: list[Node] = []
    new_index: dict[int, int] = {}

    def src(i: int, k: int) -> int:
        try:
            return new_index[int(i)]
        except (KeyError, TypeError, ValueError):
            msg = f"{where}: node {k} refers to input {i!r}, which is not an earlier node"
            raise BadProgram(msg) from None

    for k, node in enumerate(nodes):
        kind = str(node.get("type"))
        inputs = list(node.get("inputs", []))
        values = [str(v) for v in node.get("value_inputs", [])]
        if kind in ("scene", "idle"):
            out.append(Node(kind))
        elif kind in ("filter_type", "filter_color"):
            out.append(Node("filter", (src(inputs[0], k),), (values[0].lower(),)))
        elif kind == "unique":
            out.append(Node("unique", (src(inputs[0], k),)))
        elif kind == "relate":
            i = src(inputs[0], k)
            if out[i].op in _SET_OPS:
                out.append(Node("unique", (i,)))
                i = len(out) - 1
            out.append(Node("relate", (i,), (values[0].lower(),)))
        elif kind == "move":
            moved, base, chain = (src(v, k) for v in inputs)
            out.append(Node("move", (chain, moved, base), (values[0].lower(),)))
        else:
            msg = (
                f"{where}: node {k} has type {kind!r}, which has no equivalent in the DSL "
                "(scene, filter_type, filter_color, relate, unique, move, idle); "
                "this example cannot be imported"
            )
            raise BadProgram(msg)
        new_index[k] = len(out) - 1
    return Program(tuple(out))


def _references(program: Program) -> tuple[ReferenceLabel, ...]:
    refs = []
    for step, i in enumerate(program.steps):
        node = program.nodes[i]
        for role, j in (("subject", node.inputs[1]), ("reference", node.inputs[2])):
            refs.append(ReferenceLabel(step, role, program.uses(j, "relate"), False))
    return tuple(refs)


def symbolic_from_demo(demo: dict[str, Any], *, episode_id: str, index: int) -> SymbolicEpisode:
    """The :class:`SymbolicEpisode` of one original ``demo.json``."""
    where = f"example {episode_id}"
    try:
        objects = tuple(
            SceneObject(str(o["type"]).lower(), str(o["color"][1]).lower())
            for o in demo["objects"]
        )
        rotations = [tuple(float(v) for v in o.get("rotation", (0, 0, 0, 1)))
                     for o in demo["objects"]]
        states = tuple(
            tuple(Pose((float(p[0]), float(p[1]), float(p[2])),
                       (rot[0], rot[1], rot[2], rot[3]))
                  for p, rot in zip(positions, rotations, strict=True))
            for positions in demo["object_positions"]
        )
        grounded = tuple(GroundedStep(str(a).lower(), int(m), int(b))
                         for a, m, b in demo["grounded_program"])
        program = convert_program(demo["program"], where)
        template_file = Path(str(demo.get("template_json_filename", "unknown"))).stem
        instruction = Instruction(
            text=str(demo["instruction"]),
            template_id=f"nsrm-{template_file}-{demo.get('template_id', 0)}",
            phrasing=str(demo.get("language_complexity", "simple")),
            lexed=str(demo.get("instruction_lexed", "")),
        )
        return SymbolicEpisode(
            id=episode_id,
            generator=GENERATOR_ID,
            seed=SeedInfo(0, index),
            scene=Scene(objects, states[0], ORIGINAL_WORKSPACE),
            program=program,
            grounded=grounded,
            instruction=instruction,
            states=states,
            references=_references(program),
        )
    except NSRMPError as exc:
        msg = f"{where}: {exc}"
        raise InvalidArgument(msg) from exc
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        msg = (
            f"{where}: demo.json lacks or mangles a field ({exc!r}); expected the keys "
            "objects, object_positions, program, grounded_program, instruction"
        )
        raise InvalidArgument(msg) from exc


# -- images -------------------------------------------------------------------------------
def _read_png(path: Path) -> NDArray[Any]:
    cv2 = require("cv2")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        msg = f"{path} is not a readable PNG; re-extract the original release"
        raise InvalidArgument(msg)
    return np.asarray(img)


def _visible_boxes(seg: NDArray[np.int16], n: int) -> NDArray[np.float32]:
    out = np.full((n, 4), np.nan, np.float32)
    for j in range(n):
        ys, xs = np.nonzero(seg == j)
        if ys.size:
            out[j] = (xs.min(), ys.min(), xs.max() + 1, ys.max() + 1)
    return out


def _amodal(cam: Camera, sym: SymbolicEpisode, k: int) -> NDArray[np.float32]:
    ext = np.array([ORIGINAL_EXTENTS[o.shape] for o in sym.scene.objects])
    pos = np.array([p.position for p in sym.states[k]])
    orn = np.array([p.orientation for p in sym.states[k]])
    return cam.amodal_boxes(ext, pos, orn)


def _iou(a: NDArray[np.float32], b: NDArray[np.float32]) -> float:
    ok = np.all(np.isfinite(a), 1) & np.all(np.isfinite(b), 1)
    if not ok.any():
        return 0.0
    a, b = a[ok], b[ok]
    iw = np.clip(np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0]), 0, None)
    ih = np.clip(np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1]), 0, None)
    inter = iw * ih
    union = ((a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
             + (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]) - inter)
    return float(np.mean(inter / np.maximum(union, 1e-9)))


@dataclass(frozen=True)
class _Scene:
    rgb: NDArray[np.uint8]
    depth_png: NDArray[np.uint8]
    seg: NDArray[np.int16]


def _load_scene(folder: Path, n: int) -> _Scene:
    rgba = _read_png(folder / "rgba.png")
    if rgba.ndim != 3 or rgba.shape[2] not in (3, 4):
        msg = f"{folder / 'rgba.png'} has shape {rgba.shape}; expected an RGB(A) image"
        raise InvalidArgument(msg)
    rgb = np.ascontiguousarray(rgba[..., 2::-1])  # OpenCV gives BGR(A)
    depth = _read_png(folder / "depth.png")
    mask = _read_png(folder / "mask.png")
    if depth.ndim == 3:
        depth = depth[..., 0]
    if mask.ndim == 3:
        mask = mask[..., 0]
    ids = mask.astype(np.int32) - _MASK_OFFSET
    seg = np.where((ids >= 0) & (ids < n), ids, -1).astype(np.int16)
    return _Scene(rgb, depth.astype(np.uint8), seg)


def _depth_metres(cam: Camera, png: NDArray[np.uint8]) -> NDArray[np.float32]:
    zbuf = 0.9 + png.astype(np.float64) / 2550.0
    return cam.linearize_depth(np.clip(zbuf, 0.0, 1.0))


def _choose_camera(name: str, sym: SymbolicEpisode, first: _Scene, where: str
                   ) -> tuple[str, Camera]:
    h, w = first.seg.shape
    if name != "auto":
        if name not in NSRM_CAMERAS:
            msg = f"unknown camera preset {name!r}; expected auto or one of {list(NSRM_CAMERAS)}"
            raise InvalidArgument(msg)
        return name, NSRM_CAMERAS[name].resized(w, h)
    visible = _visible_boxes(first.seg, sym.num_objects)
    scored = []
    for preset, cam in NSRM_CAMERAS.items():
        c = cam.resized(w, h)
        scored.append((_iou(_amodal(c, sym, 0), visible), preset, c))
    best = max(scored, key=lambda s: s[0])
    if best[0] < 0.3:
        msg = (
            f"{where}: no camera preset matches the mask (best mean IoU {best[0]:.2f} for "
            f"{best[1]}); give camera= one of {list(NSRM_CAMERAS)} explicitly"
        )
        raise InvalidArgument(msg)
    return best[1], best[2]


def _rendering(sym: SymbolicEpisode, folders: list[Path], camera: str, where: str
               ) -> tuple[Rendering, str]:
    n, states = sym.num_objects, sym.num_steps + 1
    scenes = [_load_scene(f, n) for f in folders]
    first, last = scenes[0], scenes[-1]
    preset, cam = _choose_camera(camera, sym, first, where)
    h, w = first.seg.shape
    for s, f in zip(scenes, folders, strict=True):
        if s.seg.shape != (h, w) or s.rgb.shape[:2] != (h, w) or s.depth_png.shape != (h, w):
            msg = f"{f}: images differ in size from {folders[0]}; expected {w}x{h} everywhere"
            raise InvalidArgument(msg)
    present = [False] * states
    rgb = np.zeros((states, h, w, 3), np.uint8)
    depth = np.full((states, h, w), np.nan, np.float32)
    seg = np.full((states, h, w), -1, np.int16)
    for k, sc in ((0, first), (states - 1, last)):
        rgb[k], depth[k], seg[k] = sc.rgb, _depth_metres(cam, sc.depth_png), sc.seg
        present[k] = True
    poses = np.array([[[*p.position, *p.orientation] for p in st] for st in sym.states],
                     dtype=np.float64)
    amodal = np.stack([_amodal(cam, sym, k) for k in range(states)])
    visible = np.full((states, n, 4), np.nan, np.float32)
    for k in range(states):
        if present[k]:
            visible[k] = _visible_boxes(seg[k], n)
    _, z = cam.project(poses[..., :3])
    targets = ObjectTargets(
        poses=poses,
        boxes_amodal=amodal.astype(np.float32),
        boxes_visible=visible,
        visible_fraction=np.full((states, n), np.nan, np.float32),
        depth_centre=z.astype(np.float32),
    )
    physics = {"source": "nsrm-original", "camera_preset": preset,
               "images_present": present, "positions": "nominal"}
    rendering = Rendering(camera=cam, observations=Observations(rgb, depth, seg),
                          targets=targets, executor="nsrm-teleport", physics=physics)
    return rendering, preset


# -- examples -----------------------------------------------------------------------------
def find_examples(root: str | os.PathLike[str]) -> tuple[list[Path], list[Path]]:
    """Example folders under ``root`` (with ``demo.json``), sorted by relative path, and
    the folders that look like examples (have ``S00``) but lack ``demo.json``."""
    base = Path(root)
    if not base.is_dir():
        msg = f"{base} is not a directory; give the folder of the original NSRM release"
        raise InvalidArgument(msg)
    examples = sorted((p.parent for p in base.rglob("demo.json")),
                      key=lambda p: p.relative_to(base).as_posix())
    have = set(examples)
    broken = sorted({p.parent for p in base.rglob("S00") if p.is_dir()} - have,
                    key=lambda p: p.relative_to(base).as_posix())
    return examples, broken


def _episode_id(base: Path, folder: Path) -> str:
    rel = folder.relative_to(base).as_posix() if folder != base else folder.name
    return "nsrm-" + re.sub(r"[^A-Za-z0-9_.-]+", "-", rel).strip("-")


def load_example(base: Path, folder: Path, index: int, *, camera: str = "auto",
                 images: bool = True) -> Episode:
    """One example folder as an :class:`Episode` (rendering None without scene folders)."""
    episode_id = _episode_id(base, folder)
    try:
        demo = json.loads((folder / "demo.json").read_text("utf-8"))
    except (OSError, ValueError) as exc:
        msg = f"{folder / 'demo.json'} is unreadable or not JSON ({exc}); skip or fix it"
        raise InvalidArgument(msg) from exc
    sym = symbolic_from_demo(demo, episode_id=episode_id, index=index)
    folders = sorted(p for p in folder.glob("S[0-9][0-9]") if p.is_dir())
    if not images or not folders or not (folders[0] / "rgba.png").exists():
        return Episode(sym, None)
    if len(folders) < 2 and sym.num_steps > 0:
        msg = f"{folder}: has {folders[0].name} but no final scene folder (S01); re-extract it"
        raise InvalidArgument(msg)
    rendering, _ = _rendering(sym, folders, camera, f"example {episode_id}")
    return Episode(sym, rendering)


@dataclass(frozen=True)
class ImportReport:
    """What :func:`import_nsrm` did."""

    manifest: Manifest
    imported: int
    with_images: int
    skipped: tuple[str, ...]


def import_nsrm(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    split: str = "nsrm-original",
    shard_size: int = 1000,
    camera: str = "auto",
    images: bool = True,
    progress: Callable[[int, int], None] | None = None,
    versions: Mapping[str, str] | None = None,
) -> ImportReport:
    """Convert the original release under ``src`` into shards + manifest under ``out``.

    ``versions``: more entries for the manifest's ``versions`` (what made the data); the
    ``source`` and ``importer`` entries stay the importer's."""
    base = Path(src)
    examples, broken = find_examples(base)
    if not examples:
        msg = f"no demo.json under {base}; give the folder of the original NSRM release"
        raise InvalidArgument(msg)

    def make(i: int) -> Episode:
        ep = load_example(base, examples[i], i, camera=camera, images=images)
        if progress is not None:
            progress(i + 1, len(examples))
        return ep

    manifest = write_dataset(out, make, 0, len(examples), shard_size=shard_size, split=split,
                             versions={**(versions or {}),
                                       "source": "dair-iitd/nsrmp release layout",
                                       "importer": GENERATOR_ID})
    with open_collection(out) as coll:
        with_images = sum(ep.rendering is not None for ep in coll.iter_episodes())
    return ImportReport(manifest, len(examples), with_images,
                        tuple(p.relative_to(base).as_posix() for p in broken))
