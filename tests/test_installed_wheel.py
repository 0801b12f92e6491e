"""The built wheel works from a directory outside the repository, with its data files."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow

SMOKE = """
import json, nsrmp_bench, sys
from pathlib import Path
assert Path(nsrmp_bench.__file__).resolve().is_relative_to(Path(sys.argv[1]).resolve()), nsrmp_bench.__file__
from nsrmp_bench.split_specs import OFFICIAL_SPLITS, load_split
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.dsl.program import load_signatures
from nsrmp_bench.generators.templates import load_language
from nsrmp_bench.scoring.submission import load_schema
for sid in OFFICIAL_SPLITS:
    load_split(sid)
assert official_manifest("paper-v2", "test")["root_hash"]
assert load_signatures()["operations"]
assert load_language().counts()["step_templates"] >= 30
assert load_schema()
print("ok")
"""


CHECKPOINTS = """
import importlib.util, sys
from importlib import resources
from pathlib import Path
from nsrmp_bench.reference_model.registry import MODELS, load_model
from nsrmp_bench.results.model_cards import read_training_card
root = Path(str(resources.files("nsrmp_bench.reference_model").joinpath("checkpoints")))
assert str(root).startswith(sys.argv[1]), root
for mid in MODELS:
    card = read_training_card(root / f"{mid}.card.json")
    assert card.model == mid and card.parameters > 0, (mid, card)
    if importlib.util.find_spec("torch") is not None:
        model = load_model(mid)
        assert model.model_id == mid and model.kind is MODELS[mid].kind, mid
# the retired models: their cards ship (the boards read them), running one names its release
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.predictors import predictors
retired = predictors(retired=True)
assert retired
for p in retired:
    assert read_training_card(root / f"{p.id}.card.json").model == p.id
    try:
        load_model(p.id)
    except InvalidArgument as exc:
        assert "pip install" in str(exc), exc
    else:
        raise AssertionError(p.id)
# every leaderboard entry's model card ships where the entry links it
import json
entries = Path(str(resources.files("nsrmp_bench.leaderboards").joinpath("entries")))
for entry in sorted(entries.glob("*.json")):
    card = json.loads(entry.read_text("utf-8")).get("model_card")
    assert card is None or (entry.parent / card).is_file(), (entry.name, card)
print(len(MODELS))
"""


def test_wheel_runs_outside_the_repo(tmp_path: Path) -> None:
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(REPO)],
        check=True, capture_output=True,
    )
    (wheel,) = wheels.glob("nsrmp_bench-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for needed in ("nsrmp_bench/dsl/signatures.json", "nsrmp_bench/splits/paper-v2.json",
                   "nsrmp_bench/splits/manifests/paper-v2-test.json",
                   "nsrmp_bench/generators/templates/steps.json",
                   "nsrmp_bench/scoring/submission.schema.json", "nsrmp_bench/py.typed"):
        assert needed in names, f"{needed} is not packaged"
    target = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
         str(wheel)],
        check=True, capture_output=True,
    )
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    env = {**os.environ, "PYTHONPATH": str(target)}
    run = subprocess.run([sys.executable, "-c", SMOKE, str(target)], cwd=outside, env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    cli = subprocess.run(
        [sys.executable, "-m", "nsrmp_bench.cli.main", "sample", "--seed", "7", "--objects", "6"],
        cwd=outside, env=env, capture_output=True, text=True,
    )
    assert cli.returncode == 0, cli.stderr
    assert '"instruction"' in cli.stdout
    # every registered model's checkpoint and card ship, and load from the wheel
    models = subprocess.run([sys.executable, "-c", CHECKPOINTS, str(target)], cwd=outside,
                            env=env, capture_output=True, text=True)
    assert models.returncode == 0, models.stderr
    assert int(models.stdout.strip()) >= 6
