"""Core-only installs: every verb that needs torch, PyBullet or mcap ends with the one-line
missing-extra message (exit 2, no traceback), checked verb by verb.

Each verb runs in a fresh interpreter where those packages cannot be imported (a finder
refuses them, as a core-only install does; in CI's core lane they are absent anyway), with
arguments that would otherwise start work, so the check must come before any.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BLOCK = """
import importlib.abc, sys
BLOCKED = {"torch", "pybullet", "pybullet_data", "mcap", "mcap_protobuf",
           "foxglove_schemas_protobuf", "cv2"}
class Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None
sys.meta_path.insert(0, Refuse())
from nsrmp_bench.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


CASES = [
    (["generate", "--split", "smoke-v2", "--out", "OUT"], "sim"),
    (["replay", "PRED", "--data", "DATA", "--out", "OUT"], "sim"),
    (["export-mcap", "DATA", "--out", "OUT/x.mcap"], "mcap"),
    (["train", "nsrm", "--data", "DATA", "--out", "OUT"], "torch"),
    (["train", "detector", "--data", "DATA", "--out", "OUT"], "torch"),
    (["predict", "nsrm", "--data", "DATA", "--out", "OUT/p.jsonl"], "torch"),
    (["predict", "dense", "--data", "DATA", "--out", "OUT/p.jsonl"], "torch"),
    (["detect", "--detector", "learned", "--data", "DATA", "--out", "OUT/d.jsonl"], "torch"),
    (["reconstruct", "PRED", "--data", "DATA", "--out", "OUT"], "torch"),
    (["reconstruct", "PRED", "--data", "DATA", "--out", "OUT", "--renderer", "sim"], "sim"),
    (["evaluate", "nsrm", "--data-root", "DATA", "--out", "OUT"], "torch"),
    (["import-original", "DATA", "--out", "OUT", "--examples", "3"], "sim"),
]


@pytest.mark.parametrize(("argv", "extra"), CASES, ids=[" ".join(c[0][:2]) for c in CASES])
def test_verb_without_its_extra_says_which_to_install(argv: list[str], extra: str,
                                                      tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    pred = tmp_path / "p.jsonl"
    pred.write_text("")
    names = {"DATA": str(data), "OUT": str(tmp_path / "out"), "PRED": str(pred)}
    args = [names.get(a, a).replace("OUT/", str(tmp_path / "out") + "/") for a in argv]
    proc = subprocess.run([sys.executable, "-c", BLOCK, *args], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'nsrmp-bench[{extra}]'" in lines[0], proc.stderr
    assert not (tmp_path / "out").exists()
