"""The README's Python quick start runs as it stands: its ``python`` blocks, in order, in
one namespace, from a folder where ``data/smoke`` is a freshly generated smoke-v2 (what the
README's main job writes). Needs PyBullet (to generate) and torch (the DataLoader and the
model)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _section(title: str) -> str:
    text = README.read_text("utf-8")
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else None]


def python_blocks(title: str) -> list[str]:
    """The fenced ``python`` blocks of the README section ``title``, in order."""
    return re.findall(r"\n```python\n(.*?)\n```", _section(title), flags=re.S)


def test_the_quick_start_has_the_four_steps() -> None:
    code = "\n".join(python_blocks("From Python: a quick start"))
    for call in ("nsrmp_bench.open(", "data_loader(", "load_model(", "model.predict(",
                 "parse_predictions(", "nsrmp_bench.score("):
        assert call in code, call


def test_the_quick_start_runs_on_smoke(smoke_v2_root: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("torch")
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "smoke").symlink_to(smoke_v2_root, target_is_directory=True)
    namespace: dict[str, object] = {"__name__": "readme"}
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        for i, block in enumerate(python_blocks("From Python: a quick start")):
            exec(compile(block, f"README quick start block {i + 1}", "exec"), namespace)
    finally:
        os.chdir(here)
    out = capsys.readouterr().out
    assert out.startswith("16 smoke-v2/test\n"), out[:200]
    result = namespace["result"]
    iou_m = float(result.summary.at["iou_m", "value"])  # type: ignore[attr-defined]
    assert 0.0 <= iou_m <= 1.0
    assert len(namespace["predictions"]) == 16  # type: ignore[arg-type]
