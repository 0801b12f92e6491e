"""A new model is its folder plus one registration line, in the built wheel too: a copy of
the repository gets ``reference_model/toy/`` (the contract's toy model) and one
``ModelEntry`` line in ``reference_model/registry.py``, nothing else; its wheel, installed
in a fresh virtual environment (the current one's dependencies reached through a ``.pth``,
no network), imports every module, lists the toy as a dense predictor and a rollout policy,
and ``nsrmp-bench predict toy`` writes a predictions file the public checker accepts."""

from __future__ import annotations

import os
import pkgutil
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

pytest.importorskip("torch")

REPO = Path(__file__).resolve().parents[1]
TOY = REPO / "tests" / "models" / "toy_model" / "__init__.py"
LINE = ('    ModelEntry("toy-v1", Kind.DENSE, "a toy that shows the contract", '
        'f"{_HERE}.toy:ToyModel"),\n')


CHECK = r"""
import importlib, pkgutil, sys
from pathlib import Path
import nsrmp_bench
assert Path(nsrmp_bench.__file__).resolve().is_relative_to(Path(sys.argv[1]).resolve()), \
    nsrmp_bench.__file__
failed = []
for info in pkgutil.walk_packages(nsrmp_bench.__path__, "nsrmp_bench."):
    try:
        importlib.import_module(info.name)
    except Exception as exc:  # every module of the wheel imports
        failed.append(f"{info.name}: {exc!r}")
assert not failed, failed
from nsrmp_bench.envs.policies import policy_names
from nsrmp_bench.predictors import Kind, get_predictor
assert get_predictor("toy").kind is Kind.DENSE
assert "toy" in policy_names() and "toy-v1" in policy_names()
import torch
from nsrmp_bench.reference_model.checkpoints import save_checkpoint
from nsrmp_bench.reference_model.registry import get_model
cls = get_model("toy").model_cls()
net = cls.build_network(cls.config_cls(), 0, {})
torch.manual_seed(0)
save_checkpoint(Path(sys.argv[2]), "toy-v1", cls.config_cls().to_dict(), [], net.state_dict())
print("ok")
"""


def _copy_repo(target: Path) -> None:
    """The repository's files as git sees them, committed or not (the leaderboard's predictions
    and site aside)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                             "--exclude-standard"], cwd=REPO, check=True,
                            capture_output=True).stdout.decode().split("\0")
    for name in filter(None, listed):
        if name.startswith(("leaderboards/predictions/", "leaderboards/site/", "tests/")):
            continue
        source = REPO / name
        if source.is_file():
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / name)


def _add_the_toy(repo: Path) -> None:
    """Its folder, and one line in the registry: nothing else."""
    (repo / "reference_model" / "toy").mkdir()
    shutil.copy(TOY, repo / "reference_model" / "toy" / "__init__.py")
    registry = repo / "reference_model" / "registry.py"
    text = registry.read_text("utf-8")
    anchor = "):\n    register(_entry)\n"
    assert text.count(anchor) == 1, "the registry's entry list has moved: update this test"
    registry.write_text(text.replace(anchor, LINE + anchor), "utf-8")


@pytest.mark.slow
def test_a_new_model_is_a_folder_and_one_line_in_the_wheel(
        tmp_path: Path, smoke_v2_test: Path) -> None:
    repo = tmp_path / "repo"
    _copy_repo(repo)
    _add_the_toy(repo)
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(wheels), str(repo)], check=True, capture_output=True)
    (wheel,) = wheels.glob("nsrmp_bench-*.whl")
    assert "nsrmp_bench/reference_model/toy/__init__.py" in zipfile.ZipFile(wheel).namelist()

    venv = tmp_path / "fresh"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; "
                                "print(sysconfig.get_paths()['purelib'])"], check=True,
                               capture_output=True, text=True).stdout.strip())
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-compile", "-q",
                    "--target", str(site), str(wheel)], check=True, capture_output=True)
    # the dependencies from this environment, after the wheel (a path, not its .pth files:
    # this environment's editable install of the repository stays out)
    (site / "zz-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    outside = tmp_path / "elsewhere"
    outside.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    checkpoint = outside / "toy.pt"
    run = subprocess.run([str(python), "-c", CHECK, str(site), str(checkpoint)], cwd=outside,
                         env=env, capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.strip().endswith("ok"), run.stderr[-3000:]
    predictions = outside / "toy.jsonl"
    cli = [str(python), "-m", "nsrmp_bench.cli.main"]
    run = subprocess.run([*cli, "predict", "toy", "--data", str(smoke_v2_test), "--checkpoint",
                          str(checkpoint), "--out", str(predictions), "--quiet"],
                         cwd=outside, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    run = subprocess.run([*cli, "check-submission", str(predictions), "--split",
                          "smoke-v2/test", "--data", str(smoke_v2_test)], cwd=outside, env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def test_every_package_folder_ships() -> None:
    """What ``setup.py`` finds is every folder with an ``__init__.py`` under the three."""
    sys.path.insert(0, str(REPO))
    try:
        import setup as build  # type: ignore[import-not-found]
    finally:
        sys.path.remove(str(REPO))
    found = set(build.packages())
    for name, folder in build.MAPPED.items():
        for info in pkgutil.walk_packages([str(REPO / folder)], f"{name}."):
            if info.ispkg:
                assert info.name in found, info.name
