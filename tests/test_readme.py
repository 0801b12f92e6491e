"""Every code block of the README and of the documentation pages (``docs/*.md``) works as
it stands.

- ``python`` blocks run, in order, in one namespace per page, from a folder where
  ``data/smoke`` is a freshly generated smoke-v2 (what the main job writes). Needs PyBullet
  (to generate) and torch (the DataLoader and the model).
- ``bash`` blocks: every ``nsrmp-bench VERB ...`` command (``.venv/bin/`` or not) names a
  verb, and its arguments parse with that verb's parser.
- ``json`` blocks parse.

A block not meant to run (it needs a large split, a cluster or an account) has the marker
``<!-- no-run -->`` on the line right before its fence (docs/development.md says so).
Files the site includes at build time (model cards, ``FORMAT.md``, ``SCORING.md``) are not
pages and are not run here."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
PAGES = sorted((REPO / "docs").rglob("*.md"))
NO_RUN = "<!-- no-run -->"
FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>[\w-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ \t]*$",
                   re.M | re.S)


@dataclass(frozen=True)
class Block:
    path: Path
    line: int
    lang: str
    code: str
    run: bool

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(REPO)}:{self.line}"


def code_blocks(path: Path) -> list[Block]:
    """The fenced code blocks of a Markdown file, in order, dedented; ``run`` is False
    where the line before the fence is the no-run marker."""
    text = path.read_text("utf-8")
    blocks = []
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1].strip()
        body = textwrap.dedent(re.sub(rf"^{m.group('indent')}", "", m.group("body"),
                                      flags=re.M))
        blocks.append(Block(path, text.count("\n", 0, m.start()) + 1, m.group("lang"),
                            body, before != NO_RUN))
    return blocks


def _section(title: str) -> str:
    text = README.read_text("utf-8")
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else None]


def python_blocks(title: str) -> list[str]:
    """The fenced ``python`` blocks of the README section ``title``, in order."""
    return re.findall(r"\n```python\n(.*?)\n```", _section(title), flags=re.S)


def test_the_readme_is_short_and_the_quick_start_has_the_four_steps() -> None:
    assert len(README.read_text("utf-8").splitlines()) <= 300
    code = "\n".join(python_blocks("From Python: a quick start"))
    for call in ("nsrmp_bench.open(", "data_loader(", "load_model(", "model.predict(",
                 "parse_predictions(", "nsrmp_bench.score("):
        assert call in code, call


def test_every_page_with_code_is_found() -> None:
    langs = {b.lang for p in [README, *PAGES] for b in code_blocks(p)}
    assert {"python", "bash", "json"} <= langs, langs
    unknown = langs - {"python", "bash", "json", "yaml", "bibtex", "text", ""}
    assert not unknown, f"no check for code blocks of {sorted(unknown)}: add one here"


def _pages_with_python() -> list[Path]:
    return [p for p in [README, *PAGES] if any(b.lang == "python" for b in code_blocks(p))]


@pytest.mark.slow
@pytest.mark.parametrize("page", _pages_with_python(), ids=lambda p: str(p.relative_to(REPO)))
def test_python_blocks_run(page: Path, smoke_v2_root: Path, tmp_path: Path) -> None:
    pytest.importorskip("torch")
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "smoke").symlink_to(smoke_v2_root, target_is_directory=True)
    namespace: dict[str, object] = {"__name__": "docs"}
    out = io.StringIO()
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(out):
            for block in code_blocks(page):
                if block.lang == "python" and block.run:
                    exec(compile(block.code, block.where, "exec"), namespace)
    finally:
        os.chdir(here)
    if "From Python: a quick start" in page.read_text("utf-8"):
        assert out.getvalue().startswith("16 smoke-v2/test\n"), out.getvalue()[:200]
        result = namespace["result"]
        iou_m = float(result.summary.at["iou_m", "value"])  # type: ignore[attr-defined]
        assert 0.0 <= iou_m <= 1.0
        assert len(namespace["predictions"]) == 16  # type: ignore[arg-type]


def _commands(block: Block) -> list[list[str]]:
    """The ``nsrmp-bench`` commands of a bash block, each as its argument list."""
    commands = []
    for line in re.sub(r"\\\n", " ", block.code).splitlines():
        lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
        lexer.whitespace_split = True
        command: list[str] = []
        for word in [*lexer, ";"]:
            if word in ("&&", "||", ";", "|", "&"):
                while command and re.fullmatch(r"\w+=.*", command[0]):  # VAR=value cmd
                    command.pop(0)
                if command and command[0] in ("nsrmp-bench", ".venv/bin/nsrmp-bench"):
                    commands.append(command[1:])
                command = []
            else:
                command.append(word)
    return commands


def _bash_blocks() -> list[Block]:
    return [b for p in [README, *PAGES] for b in code_blocks(p) if b.lang == "bash" and b.run]


@pytest.mark.parametrize("block", _bash_blocks(), ids=lambda b: b.where)
def test_bash_commands_parse(block: Block) -> None:
    from nsrmp_bench.cli.main import VERBS, build_parser

    for argv in _commands(block):
        if argv in (["--help"], ["--version"]):
            continue
        verb = next(a for a in argv if not a.startswith("-"))
        assert verb in VERBS, f"{block.where}: unknown verb {verb!r}"
        stderr = io.StringIO()
        try:
            with contextlib.redirect_stderr(stderr):
                build_parser(verb).parse_args(argv)
        except SystemExit as exc:
            if exc.code != 0:
                pytest.fail(f"{block.where}: `nsrmp-bench {shlex.join(argv)}` does not "
                            f"parse: {stderr.getvalue().strip()}")


@pytest.mark.parametrize("block", [b for p in [README, *PAGES] for b in code_blocks(p)
                                   if b.lang == "json" and b.run], ids=lambda b: b.where)
def test_json_blocks_parse(block: Block) -> None:
    json.loads(block.code)


def test_the_closed_loop_policy_runs_from_the_current_directory(
        smoke_v2_test: Path, tmp_path: Path) -> None:
    """The page's ``my_policy.py`` with the command in its first line, as a user runs it:
    the console script, no PYTHONPATH, the module in the current directory."""
    pytest.importorskip("gymnasium")
    block = next(b for b in code_blocks(REPO / "docs" / "closed-loop.md")
                 if b.code.startswith("# my_policy.py:"))
    (tmp_path / "my_policy.py").write_text(block.code)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "smoke").symlink_to(smoke_v2_test.parent, target_is_directory=True)
    command = shlex.split(block.code.splitlines()[0].split(":", 1)[1])
    assert command[:2] == ["nsrmp-bench", "rollout"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    script = Path(sys.executable).parent / "nsrmp-bench"
    done = subprocess.run([str(script), *command[1:]], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "p.jsonl").is_file()
