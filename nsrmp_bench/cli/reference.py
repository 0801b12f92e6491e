"""The command-line reference as Markdown, rendered from the argparse parsers themselves.

The documentation site's CLI page is this module's output (``docs/hooks.py`` inserts it at
build time), so it cannot drift from ``nsrmp-bench <verb> --help``::

    python -m nsrmp_bench.cli.reference > cli.md
"""

from __future__ import annotations

import argparse
import contextlib
import os
from collections.abc import Iterator

from nsrmp_bench.cli.main import GROUPS, VERBS, build_parser

__all__ = ["WIDTH", "render_help", "render_markdown"]

WIDTH = 100
"""Columns the help texts are wrapped to (argparse reads ``COLUMNS``)."""


@contextlib.contextmanager
def _columns(width: int) -> Iterator[None]:
    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = before


def render_help(verb: str | None = None, width: int = WIDTH) -> str:
    """``nsrmp-bench [VERB] --help`` as the command prints it, ``width`` columns wide."""
    with _columns(width):
        parser = build_parser(verb)
        if verb is None:
            return parser.format_help()
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction) and verb in action.choices:
                return str(action.choices[verb].format_help())
    msg = f"unknown verb {verb!r}; expected one of {', '.join(VERBS)}"
    raise KeyError(msg)


def _fence(text: str) -> str:
    return "```text\n" + text.rstrip("\n") + "\n```\n"


def render_markdown(width: int = WIDTH) -> str:
    """Every verb's help, grouped as ``nsrmp-bench --help`` lists them, as Markdown."""
    grouped = [v for verbs in GROUPS.values() for v in verbs]
    others = tuple(v for v in VERBS if v not in grouped)
    groups = {**GROUPS, **({"other": others} if others else {})}
    parts = ["## `nsrmp-bench`\n", _fence(render_help(None, width))]
    for group, verbs in groups.items():
        parts.append(f"## {group.capitalize()}\n")
        for verb in verbs:
            parts.append(f"### `nsrmp-bench {verb}`\n\n{VERBS[verb]}.\n")
            parts.append(_fence(render_help(verb, width)))
    return "\n".join(parts)


if __name__ == "__main__":
    print(render_markdown(), end="")
