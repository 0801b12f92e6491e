"""The committed leaderboards are re-computable from their entries and the data."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from nsrmp_bench.dispatch import lowest_dispatch_env
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import load_entries
from nsrmp_bench.results.publish import publish
from nsrmp_bench.results.summary import Results

pytestmark = pytest.mark.sim

BOARDS = Path(__file__).resolve().parents[2] / "leaderboards"


def _entries(tmp_path: Path, splits: set[str]) -> Path:
    """The entries of ``splits`` in ``tmp_path/leaderboards/entries``, beside links to the
    committed predictions and models (an entry's paths stay inside its repository)."""
    boards = tmp_path / "leaderboards"
    entries = boards / "entries"
    entries.mkdir(parents=True, exist_ok=True)
    if not (boards / "predictions").exists():
        (boards / "predictions").symlink_to(BOARDS / "predictions", target_is_directory=True)
        (tmp_path / "reference_model").symlink_to(BOARDS.parent / "reference_model",
                                                  target_is_directory=True)
    for entry in load_entries(BOARDS / "entries"):
        if entry.split in splits:
            source = BOARDS / "entries" / f"{entry.name}.json"
            (entries / source.name).write_text(source.read_text())
    return entries


def test_smoke_board_rebuilds_to_the_committed_bytes(smoke_dir: Path, tmp_path: Path) -> None:
    entries = _entries(tmp_path, {"smoke-v2/test"})
    root = tmp_path / "data"
    root.mkdir()
    (root / "smoke-v2").symlink_to(smoke_dir, target_is_directory=True)
    boards, _ = publish(entries, root, tmp_path / "out")
    models = [r["model"] for r in boards["smoke-v2/test"]]
    assert models[0] == "oracle-v1"
    assert {"nsrm-v1", "nmn-v1", "dense-v1", "random-v1", "noop-v1"} <= set(models)
    for suffix in (".json", ".md"):
        rebuilt = (tmp_path / "out" / f"smoke-v2-test{suffix}").read_text()
        assert rebuilt == (BOARDS / f"smoke-v2-test{suffix}").read_text()
    # the site's runs (with their breakdown) are the committed ones, but for where the
    # predictions file lies relative to this site
    def runs(folder: Path) -> list[dict[str, object]]:
        out = [r.to_json() for r in Results.read(folder).on("smoke-v2/test")]
        return [{k: v for k, v in r.items() if k != "predictions"} for r in out]

    assert runs(tmp_path / "out" / "site") == runs(BOARDS / "site")
    assert (tmp_path / "out" / "site" / "smoke-v2-test.html").is_file()


@pytest.fixture(scope="module")
def board_data(smoke_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """smoke-v2 and paper-v2/test (1,000 episodes, about 30 s with 2 workers)."""
    from nsrmp_bench.generators.generate import generate_part
    from nsrmp_bench.split_specs import load_split

    root = tmp_path_factory.mktemp("boards")
    (root / "smoke-v2").symlink_to(smoke_dir, target_is_directory=True)
    generate_part(load_split("paper-v2"), "test", root / "paper-v2" / "test", workers=2)
    return root


@pytest.mark.slow
@pytest.mark.parametrize("dispatch", ["default", "lowest"])
def test_every_board_rebuilds_to_the_committed_bytes_under_any_dispatch(
    board_data: Path, tmp_path: Path, dispatch: str
) -> None:
    """`nsrmp-bench leaderboard` in a process with numpy's default SIMD dispatch and
    OpenBLAS core, and in one with only numpy's baseline and a pre-AVX OpenBLAS core
    (BLAS kernels used to change the bootstrap bounds' last digits)."""
    entries = _entries(tmp_path, {"smoke-v2/test", "paper-v2/test"})
    env = {k: v for k, v in os.environ.items()
           if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE", "OPENCV_CPU_DISABLE")}
    if dispatch == "lowest":
        if platform.machine().lower() not in {"x86_64", "amd64"}:
            pytest.skip("the lowest-dispatch settings are named for x86-64")
        env.update(lowest_dispatch_env())
    out = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "nsrmp_bench.cli.main", "leaderboard", "--data",
                    str(board_data), "--entries", str(entries), "--out", str(out),
                    "--no-site"],
                   env=env, check=True, capture_output=True, timeout=300)
    for name in ("paper-v2-test", "smoke-v2-test"):
        for suffix in (".json", ".md"):
            rebuilt = (out / f"{name}{suffix}").read_text()
            assert rebuilt == (BOARDS / f"{name}{suffix}").read_text(), f"{name}{suffix}"


def test_bad_entries_name_the_fix(tmp_path: Path) -> None:
    (tmp_path / "x.json").write_text(json.dumps({"model": "m"}))
    with pytest.raises(InvalidArgument, match=r"needs 'model', 'split'.*'predictions'"):
        load_entries(tmp_path)
    (tmp_path / "x.json").write_text(json.dumps({"model": "m", "split": "paper-v2",
                                                  "predictions": "p.jsonl"}))
    with pytest.raises(InvalidArgument, match=r"must name a part, e.g. 'paper-v2/test'"):
        load_entries(tmp_path)
