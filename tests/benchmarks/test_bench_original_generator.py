"""benchmarks/bench_original_generator.py without the original tree (CI has no internet): its
clear errors, and its shim and counting on a stand-in construct.py (a tiny render)."""

from __future__ import annotations

import os
from pathlib import Path
from types import ModuleType

import pytest
from script_module import BENCHMARKS, load_script


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_script("bench_original_generator", BENCHMARKS)


def fake_tree(root: Path, construct: str = "", templates: tuple[str, ...] = ("SingleStep",),
              ) -> Path:
    """The files the script checks for, construct.py holding ``construct``."""
    dg = root / "data_generation"
    (dg / "panda" / "construct" / "templates").mkdir(parents=True)
    for name in ("configs.py", "manage.py", "panda/construct/program_generator.py"):
        (dg / name).write_text("")
    (dg / "panda" / "construct" / "metadata.json").write_text("{}")
    for t in templates:
        (dg / "panda" / "construct" / "templates" / f"{t}.json").write_text("{}")
    (dg / "construct.py").write_text(construct)
    return root


def test_missing_tree_says_how_to_get_it(bench: ModuleType, tmp_path: Path) -> None:
    missing = tmp_path / "nsrmp"
    with pytest.raises(bench.OriginalGeneratorError) as e:
        bench.original_seconds_per_sample(missing, scenes=1, seed=0)
    msg = str(e.value)
    assert str(missing) in msg and "does not exist" in msg
    assert "git clone https://github.com/dair-iitd/nsrmp" in msg and "bf6ba54" in msg


def test_a_file_is_not_a_tree(bench: ModuleType, tmp_path: Path) -> None:
    (tmp_path / "f").write_text("")
    with pytest.raises(bench.OriginalGeneratorError, match="is a file"):
        bench.data_generation_dir(tmp_path / "f")


def test_tree_without_construct_py(bench: ModuleType, tmp_path: Path) -> None:
    fake_tree(tmp_path)
    (tmp_path / "data_generation" / "construct.py").unlink()
    with pytest.raises(bench.OriginalGeneratorError) as e:
        bench.original_seconds_per_sample(tmp_path, scenes=1, seed=0)
    msg = str(e.value)
    assert "not the original NSRMP repository's layout" in msg
    assert "data_generation/construct.py missing" in msg and "git clone" in msg


def test_empty_folder_names_every_missing_file(bench: ModuleType, tmp_path: Path) -> None:
    with pytest.raises(bench.OriginalGeneratorError, match=r"data_generation/construct\.py, "
                       r"data_generation/configs\.py"):
        bench.data_generation_dir(tmp_path)


def test_unknown_template_lists_the_known(bench: ModuleType, tmp_path: Path) -> None:
    fake_tree(tmp_path, templates=("DoubleStep", "SingleStep"))
    with pytest.raises(bench.OriginalGeneratorError,
                       match=r"--template Triple: .*expected one of DoubleStep, SingleStep"):
        bench.data_generation_dir(tmp_path, "Triple")


def test_bad_values_are_named(bench: ModuleType, tmp_path: Path) -> None:
    fake_tree(tmp_path)
    with pytest.raises(bench.OriginalGeneratorError, match="scenes=0"):
        bench.original_seconds_per_sample(tmp_path, scenes=0, seed=0)
    with pytest.raises(bench.OriginalGeneratorError, match="language='fancy'"):
        bench.original_seconds_per_sample(tmp_path, scenes=1, seed=0, language="fancy")


def test_missing_module_names_the_pip_package(bench: ModuleType,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(bench.NEEDED_MODULES, "no_such_module_xyz", "no-such-package")
    with pytest.raises(bench.OriginalGeneratorError,
                       match=r"no_such_module_xyz.*pip install no-such-package"):
        bench.check_modules()


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity here")
def test_core_not_allowed(bench: ModuleType) -> None:
    allowed = sorted(os.sched_getaffinity(0))
    assert bench.pick_core(None) == allowed[-1]
    with pytest.raises(bench.OriginalGeneratorError, match=r"--core 100000: .*cores"):
        bench.pick_core(100000)


def test_cli_prints_the_error(bench: ModuleType, tmp_path: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--tree", str(tmp_path / "none"), "--scenes", "1"]) == 2
    assert "error: --tree" in capsys.readouterr().err


# A stand-in construct.py: what the original does with PyBullet (GUI connect, debug camera,
# getCameraImage without matrices; width and height as strings), then one sample folder per
# scene, with a demo.json unless told not to.
STAND_IN = """
import argparse, json, os, random
import pybullet as p
ap = argparse.ArgumentParser()
for a in ("--template_file", "--metadata_file", "--dataset_dir", "--type", "--language",
          "--width", "--height"):
    ap.add_argument(a)
ap.add_argument("--max_objects", type=int)
ap.add_argument("--num_examples", type=int)
args = ap.parse_args()
assert os.path.isfile(args.template_file) and os.getcwd().endswith("data_generation")
os.mkdir(args.dataset_dir)
for i in range(args.num_examples):
    p.connect(p.GUI)
    p.resetDebugVisualizerCamera(cameraDistance=12.3, cameraYaw=0, cameraPitch=-46,
                                 cameraTargetPosition=[0, 8.0, -7.5])
    w, h, rgba, depth, mask = p.getCameraImage(width=args.width or "8", height=args.height or "6")
    d = os.path.join(args.dataset_dir, "%04d" % i)
    os.mkdir(d)
    if WRITE_DEMO:
        with open(os.path.join(d, "demo.json"), "w") as f:
            json.dump({"w": w, "h": h, "r": random.random(), "language_complexity": "simple"}, f)
    p.disconnect()
    print("*******NO compatible program found *******")
    print("'complex'")
"""


@pytest.mark.sim
def test_shim_runs_a_stand_in_and_counts(bench: ModuleType, tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    tree = fake_tree(tmp_path / "tree", "WRITE_DEMO = True\n" + STAND_IN)
    keep = tmp_path / "kept"
    runs = [bench.original_seconds_per_sample(tree, scenes=2, seed=3, width=8, height=6,
                                              keep=keep / str(i)) for i in range(2)]
    run = runs[0]
    assert (run.spec.scenes, run.sample_dirs, len(run.samples), run.no_program) == (2, 2, 2, 2)
    assert run.other_messages == (("'complex'", 2),)
    assert run.languages == ("simple",)
    assert run.seconds_per_sample == pytest.approx(run.wall_s / 2)
    assert run.runpy_s is not None and 0 < run.runpy_s <= run.wall_s
    demo = (run.dataset / "0000" / "demo.json").read_text()
    assert '"w": 8, "h": 6' in demo
    # seeded: the same draws in both runs
    assert demo == (runs[1].dataset / "0000" / "demo.json").read_text()
    with pytest.raises(bench.OriginalGeneratorError, match="exists"):
        bench.original_seconds_per_sample(tree, scenes=1, seed=0, keep=keep / "0")


@pytest.mark.sim
def test_no_sample_is_an_error_with_the_output(bench: ModuleType, tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    tree = fake_tree(tmp_path, "WRITE_DEMO = False\n" + STAND_IN)
    with pytest.raises(bench.OriginalGeneratorError) as e:
        bench.original_seconds_per_sample(tree, scenes=1, seed=0, width=8, height=6)
    msg = str(e.value)
    assert "wrote no sample with a demo.json (1 sample folders)" in msg
    assert "NO compatible program found" in msg  # the tail of the child's output
