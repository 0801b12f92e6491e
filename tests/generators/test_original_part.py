"""The cross-generator TEST part: examples the original authors' generator made.

The import path runs on the committed fixture (tests/fixtures/original-nsrmp: nine examples
staged by ``stage_original`` from dair-iitd/nsrmp at bf6ba54, 128x96), with no tree. The run
of the original generator itself needs its tree: set NSRMP_ORIGINAL_TREE to the root of
dair-iitd/nsrmp at bf6ba54, else those tests skip.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import nsrmp_bench
from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.original.part import (
    CAMERA_PRESET,
    PINS_NAME,
    import_staged,
    make_original_part,
    read_pins,
    stage_original,
)
from nsrmp_bench.generators.original.shim import SHIM_VERSION
from nsrmp_bench.generators.original.tree import (
    ORIGINAL_COMMIT,
    check_pinned,
    git_blob_id,
    pinned_files,
)

pytest.importorskip("cv2")

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "original-nsrmp"
RUNS = sorted(p.name for p in FIXTURE.iterdir() if p.is_dir())
TREE = os.environ.get("NSRMP_ORIGINAL_TREE")
needs_tree = pytest.mark.skipif(not TREE, reason="NSRMP_ORIGINAL_TREE (the root of "
                                "dair-iitd/nsrmp at bf6ba54) is not set")


@pytest.fixture(scope="module")
def part(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("original") / "test"
    import_staged(FIXTURE, out)
    return out


def test_fixture_is_the_original_layout() -> None:
    assert len(RUNS) == 9
    for run in RUNS:
        example = FIXTURE / run / "0000"
        demo = json.loads((example / "demo.json").read_text())
        assert {"instruction", "program", "grounded_program", "object_positions"} <= set(demo)
        for scene in ("S00", "S01"):
            assert {p.name for p in (example / scene).iterdir()} == {
                "rgba.png", "depth.png", "mask.png"}


def test_import_keeps_ids_and_pins(part: Path) -> None:
    with nsrmp_bench.open(part) as coll:
        episodes = list(coll.iter_episodes())
        manifest = coll.manifest
    assert [e.id for e in episodes] == [f"nsrm-{run}-0000" for run in RUNS]
    assert all(e.rendering is not None for e in episodes)
    assert {e.rendering.camera.width for e in episodes if e.rendering} == {128}
    assert manifest.split == "original-v1/test"
    v = manifest.versions
    assert v["original_commit"] == ORIGINAL_COMMIT and v["shim"] == SHIM_VERSION
    assert (v["seed"], v["examples"], v["image_size"], v["camera"]) == (
        "0", "9", "128x96", CAMERA_PRESET)
    assert v["templates"].split(",") == ["SingleStep", "DoubleStep", "RelationalSingleStep",
                                         "RelationalDoubleStep",
                                         "RelationalDoubleStepCornerCases"]
    runs = json.loads(v["original_runs"])
    assert [r["run"] for r in runs] == RUNS
    for r in runs:
        command = r["attempts"][-1]["command"]
        assert f"templates/{r['template']}.json" in command
        assert f"--max_objects {r['objects']} --language {r['language']}" in command
        assert command.split()[3] == str(r["attempts"][-1]["seed"])
    # the steps and the relational templates are both there
    assert {e.symbolic.num_steps for e in episodes} == {1, 2}
    assert {e.symbolic.program.uses(i, "relate") for e in episodes
            for i in e.symbolic.program.steps} >= {True}


def test_oracle_scores_through_the_public_scorer(part: Path, tmp_path: Path) -> None:
    preds, figures = tmp_path / "oracle.jsonl", tmp_path / "oracle.json"
    assert main(["baseline", "oracle", "--data", str(part), "--out", str(preds)]) == 0
    assert main(["score", str(preds), "--data", str(part), "--json", str(figures),
                 "--quiet"]) == 0
    summary = json.loads(figures.read_text())["summary"]
    assert summary["iou_m"]["n"] == 9
    assert summary["program_exact"]["value"] == 1.0 and summary["success"]["value"] == 1.0
    # the gold program executed with our action geometry: its boxes are not the original's
    # (docs/cross-generator.md says why), so IoU-M is below 1
    assert 0.5 < summary["iou_m"]["value"] < 0.95


# The original's action rule (reference/nsrm-original-datagen.md section 2.3): its object
# size D is 5 cm for cube and dice and 6.25 cm for lego in every dimension; left/right keep
# the base's z. Ours uses true extents and puts a moved object on the table top.
ORIGINAL_D = {"cube": 0.05, "dice": 0.05, "lego": 0.0625}


def _original_target(action: str, moved: str, base: str,
                     at: tuple[float, float, float]) -> tuple[float, float, float]:
    x, y, z = at
    if action == "top":
        return (x, y, z + ORIGINAL_D[base])
    if action == "left":
        return (x - ORIGINAL_D[moved] - 0.03, y, z)
    return (x + ORIGINAL_D[base] + 0.03, y, z)


def test_why_the_oracle_is_not_the_original(part: Path) -> None:
    """Gold follows the original's rule; the oracle (our geometry) differs from it exactly
    as docs/cross-generator.md says: beside a cube or dice, 1 cm higher (the original keeps
    the base's nominal z, 1 cm inside the table); on a cube or dice, the same place."""
    from nsrmp_bench.baselines.oracle import oracle_prediction
    from nsrmp_bench.episode_views import episode_positions

    checked = {"beside": 0, "on": 0}
    with nsrmp_bench.open(part) as coll:
        for ep in coll.iter_episodes():
            sym, gold = ep.symbolic, episode_positions(ep)
            shapes = [o.shape for o in sym.scene.objects]
            for k, step in enumerate(sym.grounded):
                want = _original_target(step.action, shapes[step.subject],
                                        shapes[step.reference], tuple(gold[k][step.reference]))
                assert gold[k + 1][step.subject] == pytest.approx(want, abs=1e-6)
            oracle = oracle_prediction(ep, np.random.default_rng(0)).positions
            assert oracle is not None
            last = {s.subject: k for k, s in enumerate(sym.grounded)}
            for i, k in last.items():
                step = sym.grounded[k]
                pair = {shapes[i], shapes[step.reference]}
                if "lego" in pair or gold[k][step.reference][2] != pytest.approx(0.64):
                    continue  # lego sizes differ too; a stacked base adds its own offset
                offset = oracle[i] - gold[-1][i]
                if step.action == "top":
                    assert offset == pytest.approx((0, 0, 0), abs=1e-6)
                    checked["on"] += 1
                else:
                    assert offset == pytest.approx((0, 0, 0.01), abs=1e-6)
                    checked["beside"] += 1
    assert checked["beside"] >= 2 and checked["on"] >= 1


def test_staged_folder_needs_its_pins(tmp_path: Path) -> None:
    stage = tmp_path / "stage"
    shutil.copytree(FIXTURE, stage)
    pins = json.loads((stage / PINS_NAME).read_text())
    pins["original_commit"] = "0" * 40
    (stage / PINS_NAME).write_text(json.dumps(pins))
    with pytest.raises(InvalidArgument, match=r"original_commit='0{40}'.*stage it again"):
        read_pins(stage)
    (stage / PINS_NAME).unlink()
    with pytest.raises(InvalidArgument, match=r"original-pins.json is missing"):
        import_staged(stage, tmp_path / "out")


def test_out_must_be_new_or_empty(tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "x").write_text("")
    with pytest.raises(InvalidArgument, match="is not empty"):
        import_staged(FIXTURE, tmp_path / "out")


def _tree_copy(tmp_path: Path) -> Path:
    """A tree of the original's layout whose files are not the pinned commit's."""
    dg = tmp_path / "nsrmp" / "data_generation"
    for rel in ("construct.py", "configs.py", "manage.py",
                "panda/construct/program_generator.py", "panda/construct/metadata.json",
                "panda/construct/templates/SingleStep.json"):
        (dg / rel).parent.mkdir(parents=True, exist_ok=True)
        (dg / rel).write_text("# not the original\n")
    return tmp_path / "nsrmp"


def test_wrong_tree_is_named_with_the_fix(tmp_path: Path) -> None:
    tree = _tree_copy(tmp_path)
    with pytest.raises(InvalidArgument) as e:
        check_pinned(tree)
    msg = str(e.value)
    assert f"--tree {tree} is not dair-iitd/nsrmp at bf6ba54" in msg
    assert "differ (configs.py, construct.py" in msg and "missing (" in msg
    assert "git -C" in msg and "checkout bf6ba54" in msg
    with pytest.raises(InvalidArgument, match="does not exist"):
        check_pinned(tmp_path / "nowhere")


def test_cli_refuses_a_wrong_tree_before_any_run(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    tree = _tree_copy(tmp_path)
    out = tmp_path / "part"
    assert main(["import-original", str(tree), "--out", str(out), "--examples", "3"]) == 2
    err = capsys.readouterr().err
    assert "import-original: error: --tree" in err and "is not dair-iitd/nsrmp" in err
    assert not out.exists() or not any(out.iterdir())


def test_pinned_blob_ids_are_gits(tmp_path: Path) -> None:
    empty = tmp_path / "e"
    empty.write_bytes(b"")
    assert git_blob_id(empty) == "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391"
    files = pinned_files()
    assert "construct.py" in files and "panda/construct/templates/SingleStep.json" in files


@needs_tree
@pytest.mark.sim
@pytest.mark.slow
def test_original_generator_reproduces_the_fixture(tmp_path: Path) -> None:
    """Staging the fixture's plan again gives its demo.jsons and its pins (same seed)."""
    assert TREE is not None
    stage = tmp_path / "examples"
    stage_original(TREE, stage, examples=9, seed=0, size=(128, 96))
    assert read_pins(stage) == read_pins(FIXTURE) | {
        k: v for k, v in read_pins(stage).items() if k in ("pybullet", "python")}
    for run in RUNS:
        assert ((stage / run / "0000" / "demo.json").read_bytes()
                == (FIXTURE / run / "0000" / "demo.json").read_bytes())


@needs_tree
@pytest.mark.sim
@pytest.mark.slow
def test_one_command_makes_a_part(tmp_path: Path) -> None:
    assert TREE is not None
    out = tmp_path / "test"
    report = make_original_part(TREE, out, examples=4, seed=1, size=(64, 48),
                                templates=("SingleStep", "DoubleStep"), objects=(4,))
    assert report.imported.imported == 4
    with nsrmp_bench.open(out) as coll:
        assert coll.manifest.versions["examples"] == "4"
        assert len(list(coll.iter_episodes())) == 4
