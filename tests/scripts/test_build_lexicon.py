"""``scripts/build_lexicon.py``: the committed lexicon is what it builds from Debian's WordNet
(where ``wordnet-base`` is installed), and it never reads the robustness suite's word lists
(its test lexicon above all) nor the generator's templates."""

from __future__ import annotations

import ast
import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "build_lexicon.py"
DATA = REPO / "reference_model" / "language" / "lexicon.json"
FORBIDDEN = (REPO / "nsrmp_bench" / "robustness", REPO / "generators" / "templates")


def _wordnet_present() -> bool:
    if shutil.which("dpkg") is None:
        return False
    out = subprocess.run(["dpkg", "-L", "wordnet-base"], capture_output=True, text=True)
    return out.returncode == 0 and "/data.noun" in out.stdout


def test_the_build_script_names_none_of_the_test_word_lists() -> None:
    """Statically: no import of the suite or the generator, no string naming their files
    outside the docstrings (which say it is not read)."""
    tree = ast.parse(SCRIPT.read_text("utf-8"))
    docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                  if isinstance(n, ast.Module | ast.FunctionDef | ast.ClassDef)
                  and n.body and isinstance(n.body[0], ast.Expr)
                  and isinstance(n.body[0].value, ast.Constant)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            names = [a.name for a in node.names] + [getattr(node, "module", None) or ""]
            assert not any("robustness" in n or "generators" in n for n in names), names
        if (isinstance(node, ast.Constant) and isinstance(node.value, str)
                and id(node) not in docstrings and "never used to build" not in node.value):
            text = node.value.lower()
            assert not any(w in text for w in ("robustness", "lexicon-dev", "templates")), text


@pytest.mark.skipif(not _wordnet_present(), reason="wordnet-base is not installed "
                    "(apt-get install wordnet-base)")
def test_the_committed_file_is_what_the_script_builds_and_it_reads_no_test_lexicon() -> None:
    pytest.importorskip("nltk")
    pytest.importorskip("matplotlib")
    code = f"""
import hashlib, json, os, sys
opened = []
def hook(event, args):
    if event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        opened.append(os.path.realpath(os.fsdecode(args[0])))
sys.addaudithook(hook)
sys.path.insert(0, {str(SCRIPT.parent)!r})
import build_lexicon as b
data = b.render(b.build(b.wordnet_folder()))
mods = sorted(m for m in sys.modules if "robustness" in m or "generators" in m)
print(json.dumps({{"sha": hashlib.sha256(data).hexdigest(), "opened": opened, "mods": mods}}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=REPO, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["sha"] == hashlib.sha256(DATA.read_bytes()).hexdigest(), (
        "reference_model/language/lexicon.json is not what scripts/build_lexicon.py builds: "
        "run .venv/bin/python scripts/build_lexicon.py and commit the file")
    forbidden = [str(p.resolve()) for p in FORBIDDEN]
    read = [p for p in result["opened"] if any(p.startswith(f) for f in forbidden)]
    assert read == [] and result["mods"] == [], (read, result["mods"])
    assert any(p.endswith("data.noun") for p in result["opened"])  # the hook saw the reads
