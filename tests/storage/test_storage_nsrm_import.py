"""import-nsrm: tiny fixtures of the original release layout, built here."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import BadProgram, InvalidArgument
from nsrmp_bench.storage import open
from nsrmp_bench.storage.nsrm_import import (
    NSRM_CAMERAS,
    ORIGINAL_EXTENTS,
    convert_program,
    symbolic_from_demo,
)

cv2 = pytest.importorskip("cv2")

# examples/00001/demo.json of dair-iitd/nsrmp (4 KB), shipped with the tests
REAL_DEMO = Path(__file__).resolve().parent / "fixtures" / "nsrm-original-example-demo.json"
W, H = 256, 192
BGR = {"Blue": (255, 0, 0), "Green": (0, 255, 0), "Red": (0, 0, 255), "Cyan": (255, 255, 0),
       "Yellow": (0, 255, 255), "Magenta": (255, 0, 255), "White": (255, 255, 255)}


def _real_demo() -> dict[str, Any]:
    data: dict[str, Any] = json.loads(REAL_DEMO.read_text())
    return data


def _relational_demo() -> dict[str, Any]:
    """A RelationalSingleStep-style example: move the block left of the red cube onto ..."""
    objs = [("Cube", 2, "Red"), ("Lego", 1, "Green"), ("Dice", 0, "Blue")]
    pos = [[0.1, 0.0, 0.64], [-0.1, 0.02, 0.64], [0.05, 0.2, 0.64]]
    final = [pos[0], [0.05, 0.2, 0.69], pos[2]]
    nodes = [
        {"type": "idle", "inputs": [], "value_inputs": []},
        {"type": "scene", "inputs": [], "value_inputs": []},
        {"type": "filter_color", "inputs": [1], "value_inputs": ["Red"]},
        {"type": "filter_type", "inputs": [2], "value_inputs": ["Cube"]},
        {"type": "relate", "inputs": [3], "value_inputs": ["left"]},
        {"type": "unique", "inputs": [4], "value_inputs": []},
        {"type": "scene", "inputs": [], "value_inputs": []},
        {"type": "filter_color", "inputs": [6], "value_inputs": ["Blue"]},
        {"type": "filter_type", "inputs": [7], "value_inputs": ["Dice"]},
        {"type": "unique", "inputs": [8], "value_inputs": []},
        {"type": "move", "inputs": [5, 9, 0], "value_inputs": ["TOP"]},
    ]
    return {
        "instruction": "put the block which is to the left of the red cube on top of the blue dice",
        "instruction_lexed": "Put the block <R1> the <C1> <T1> <A1> the <C2> <T2>",
        "objects": [{"type": t, "object_idx": i, "color": [c, n], "position": p,
                     "rotation": [0, 0, 0, 1]}
                    for i, ((t, c, n), p) in enumerate(zip(objs, pos, strict=True))],
        "object_positions": [pos, final],
        "template_json_filename": "./panda/construct/templates/RelationalSingleStep.json",
        "template_id": 1,
        "language_complexity": "simple",
        "is_question": False,
        "program": nodes,
        "grounded_program": [["TOP", 1, 2]],
    }


def _draw_scene(folder: Path, demo: dict[str, Any], state: int, preset: str) -> np.ndarray:
    """Write rgba/depth/mask PNGs where each object is its projected box; returns the mask."""
    cam = NSRM_CAMERAS[preset].resized(W, H)
    objs = demo["objects"]
    positions = np.array(demo["object_positions"][state])
    ext = np.array([ORIGINAL_EXTENTS[o["type"].lower()] for o in objs])
    boxes = cam.amodal_boxes(ext, positions, np.tile([0, 0, 0, 1.0], (len(objs), 1)))
    _, z = cam.project(positions)
    bgra = np.zeros((H, W, 4), np.uint8)
    bgra[..., :3], bgra[..., 3] = 60, 255
    mask = np.zeros((H, W), np.uint8)
    depth = np.full((H, W), 255, np.uint8)
    depth[H // 3 :] = 230
    for j in np.argsort(-z):  # far first, near objects drawn over them
        x0, y0, x1, y1 = (math.floor(v) for v in boxes[j])
        mask[y0:y1, x0:x1] = 3 + j
        bgra[y0:y1, x0:x1, :3] = BGR[objs[j]["color"][1]]
        depth[y0:y1, x0:x1] = 220
    folder.mkdir(parents=True)
    cv2.imwrite(str(folder / "rgba.png"), bgra)
    cv2.imwrite(str(folder / "depth.png"), depth)
    cv2.imwrite(str(folder / "mask.png"), mask)
    return mask


def _release(root: Path, preset: str) -> tuple[Path, dict[str, Any]]:
    src = root / "release"
    real = _real_demo()
    ex = src / "train" / "00001"
    ex.mkdir(parents=True)
    (ex / "demo.json").write_text(json.dumps(real))
    _draw_scene(ex / "S00", real, 0, preset)
    _draw_scene(ex / "S01", real, len(real["object_positions"]) - 1, preset)
    rel = src / "train" / "00002"
    rel.mkdir(parents=True)
    (rel / "demo.json").write_text(json.dumps(_relational_demo()))
    broken = src / "train" / "00003" / "S00"  # the original failed after rendering
    broken.mkdir(parents=True)
    return src, real


@pytest.mark.parametrize("preset", ["small_table_view", "big_table_view_2"])
def test_import_release_layout(tmp_path: Path, preset: str,
                               capsys: pytest.CaptureFixture[str]) -> None:
    src, real = _release(tmp_path, preset)
    out = tmp_path / "data"
    assert main(["import-nsrm", str(src), "--out", str(out), "--shard-size", "1"]) == 0
    printed = capsys.readouterr().out
    assert "imported 2 examples (1 with images)" in printed
    assert "skipped train/00003" in printed

    coll = open(out, verify=True)
    assert coll.ids == ["nsrm-train-00001", "nsrm-train-00002"]
    assert coll.split == "nsrm-original"
    ep = coll[0]
    sym = ep.symbolic
    assert sym.instruction.text == real["instruction"]
    assert sym.instruction.template_id == "nsrm-DoubleStep-2"
    assert sym.instruction.phrasing == "complex"
    assert [g.to_list() for g in sym.grounded] == [["top", 2, 4], ["top", 1, 2]]
    assert [(o.shape, o.colour) for o in sym.scene.objects][:3] == [
        ("cube", "magenta"), ("cube", "yellow"), ("dice", "white")]
    assert sym.program.text() == (
        "move[top](move[top](idle(), unique(filter[white](filter[dice](scene()))), "
        "unique(filter[yellow](filter[lego](scene())))), "
        "unique(filter[yellow](filter[cube](scene()))), "
        "unique(filter[white](filter[dice](scene()))))")
    assert sym.states[2][1].position == tuple(real["object_positions"][2][1])

    r = ep.rendering
    assert r is not None and r.observations is not None
    assert r.physics["camera_preset"] == preset
    assert r.physics["images_present"] == [True, False, True]
    assert (r.camera.width, r.camera.height) == (W, H)
    obs = r.observations
    assert obs.rgb.shape == (3, H, W, 3)
    np.testing.assert_array_equal(obs.rgb[1], 0)
    assert np.isnan(obs.depth[1]).all() and np.isfinite(obs.depth[[0, 2]]).all()
    assert (obs.segmentation[1] == -1).all()
    assert set(np.unique(obs.segmentation[0])) == {-1, 0, 1, 2, 3, 4, 5}
    # the white dice (object 2) shows in white, and its visible box matches its pixels
    ys, xs = np.nonzero(obs.segmentation[0] == 2)
    assert tuple(obs.rgb[0, ys[0], xs[0]]) == (255, 255, 255)
    np.testing.assert_allclose(r.targets.boxes_visible[0, 2],
                               [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1])
    assert np.isnan(r.targets.boxes_visible[1]).all()
    np.testing.assert_allclose(r.targets.boxes_amodal[0], r.targets.boxes_visible[0], atol=1.01)
    assert np.isnan(r.targets.visible_fraction).all()

    rel = coll[1]
    assert rel.rendering is None
    assert rel.symbolic.relational and rel.symbolic.categories()["relational"]
    assert "unique(relate[left](unique(filter[cube](filter[red](scene())))))" in (
        rel.symbolic.program.text())
    assert [(x.role, x.relational) for x in rel.symbolic.references] == [
        ("subject", True), ("reference", False)]


def test_no_images_flag_and_explicit_camera(tmp_path: Path) -> None:
    src, _ = _release(tmp_path, "small_table_view")
    assert main(["import-nsrm", str(src), "--out", str(tmp_path / "a"), "--no-images"]) == 0
    assert all(e.rendering is None for e in open(tmp_path / "a"))
    assert main(["import-nsrm", str(src), "--out", str(tmp_path / "b"),
                 "--camera", "big_table_view_2"]) == 0
    ep = open(tmp_path / "b")[0]
    assert ep.rendering is not None and ep.rendering.physics["camera_preset"] == (
        "big_table_view_2")


def test_programs_without_a_dsl_equivalent_are_refused() -> None:
    nodes = [{"type": "scene", "inputs": [], "value_inputs": []},
             {"type": "union", "inputs": [0, 0], "value_inputs": []}]
    with pytest.raises(BadProgram, match="'union', which has no equivalent"):
        convert_program(nodes, "example x")
    demo = _relational_demo()
    demo["program"][4]["value_inputs"] = ["above"]
    with pytest.raises(InvalidArgument, match=r"example y: .*'above' is not a relation"):
        symbolic_from_demo(demo, episode_id="y", index=0)
    del demo["grounded_program"]
    with pytest.raises(InvalidArgument, match="grounded_program"):
        symbolic_from_demo(demo, episode_id="y", index=0)


def test_empty_or_missing_source(tmp_path: Path) -> None:
    assert main(["import-nsrm", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert main(["import-nsrm", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
