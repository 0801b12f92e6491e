"""A leaderboard entry names only files inside its repository: no entry can get another
file of the maintainer's machine copied into the published site."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nsrmp_bench.errors import UnsafePath
from nsrmp_bench.leaderboard import load_entries


def _repo(tmp_path: Path) -> Path:
    """tmp/repo/leaderboards/{entries, predictions/p.jsonl}, tmp/secret/key.md beside it."""
    boards = tmp_path / "repo" / "leaderboards"
    (boards / "entries").mkdir(parents=True)
    (boards / "predictions").mkdir()
    (boards / "predictions" / "p.jsonl").write_text("{}\n")
    (tmp_path / "repo" / "cards").mkdir()
    (tmp_path / "repo" / "cards" / "CARD.md").write_text("# card\n")
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "key.md").write_text("secret\n")
    (tmp_path / "secret" / "p.jsonl").write_text("{}\n")
    return boards / "entries"


def _write(entries: Path, **fields: str) -> None:
    data = {"model": "m-v1", "split": "smoke-v2/test",
            "predictions": "../predictions/p.jsonl", **fields}
    (entries / "e.json").write_text(json.dumps(data))


def test_an_entry_inside_its_repository_is_read(tmp_path: Path) -> None:
    entries = _repo(tmp_path)
    _write(entries, model_card="../../cards/CARD.md")
    [entry] = load_entries(entries)
    assert entry.model_card == tmp_path / "repo" / "cards" / "CARD.md"


@pytest.mark.parametrize(("key", "value", "said"), [
    ("model_card", "../../../secret/key.md", "outside the repository"),
    ("model_card", "/etc/hostname.md", "an absolute path"),
    ("model_card", "../predictions/p.jsonl", "expected a file ending in .md"),
    ("predictions", "../../../secret/p.jsonl", "outside the repository"),
    ("predictions", "../../cards/CARD.md", "expected a file ending in .jsonl"),
])
def test_an_entry_naming_a_file_outside_is_refused(
    tmp_path: Path, key: str, value: str, said: str
) -> None:
    entries = _repo(tmp_path)
    _write(entries, **{key: value})
    with pytest.raises(UnsafePath, match=said) as caught:
        load_entries(entries)
    assert repr(value) in str(caught.value)


def test_a_linked_card_is_refused(tmp_path: Path) -> None:
    entries = _repo(tmp_path)
    (tmp_path / "repo" / "cards" / "LINK.md").symlink_to(tmp_path / "secret" / "key.md")
    _write(entries, model_card="../../cards/LINK.md")
    with pytest.raises(UnsafePath, match="a symbolic link"):
        load_entries(entries)
