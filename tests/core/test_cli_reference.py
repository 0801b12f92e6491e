"""The CLI reference of the documentation is every verb's own ``--help``, rendered from the
argparse parsers (``python -m nsrmp_bench.cli.reference``)."""

from __future__ import annotations

import contextlib
import io

import pytest

from nsrmp_bench.cli.main import VERBS, main
from nsrmp_bench.cli.reference import WIDTH, render_help, render_markdown


def test_every_verb_has_its_section_and_its_help() -> None:
    text = render_markdown()
    for verb in VERBS:
        assert f"### `nsrmp-bench {verb}`" in text, verb
        assert f"usage: nsrmp-bench {verb}" in text, verb
    assert text.count("```text") == len(VERBS) + 1


def test_a_verbs_help_is_what_the_command_prints(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", str(WIDTH))
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main(["score", "--help"])
    assert out.getvalue() == render_help("score")


def test_an_unknown_verb_is_named() -> None:
    with pytest.raises(KeyError, match="unknown verb 'nope'"):
        render_help("nope")
