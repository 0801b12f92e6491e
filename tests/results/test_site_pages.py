"""The committed site is recomputable: its pages rebuild from the committed boards, entries
and runs to the same bytes; model cards come from checkpoint cards, the baseline registry
or the entry."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from site_build import SITE, build_site

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.model_cards import model_card
from nsrmp_bench.results.site import read_boards


def test_committed_pages_rebuild_to_the_same_bytes(tmp_path: Path) -> None:
    site = build_site(tmp_path, figures=False)
    committed = sorted(p.relative_to(SITE) for p in SITE.rglob("*")
                       if p.suffix in {".html", ".css", ".js"})
    rebuilt = sorted(p.relative_to(site) for p in site.rglob("*")
                     if p.suffix in {".html", ".css", ".js"})
    assert rebuilt == committed
    for rel in committed:
        assert (site / rel).read_bytes() == (SITE / rel).read_bytes(), (
            f"{rel} is stale: rebuild with `nsrmp-bench leaderboard --data ROOT`")


def test_model_cards() -> None:
    nsrm = model_card("nsrm-v1")
    assert nsrm.facts["parameters"].replace(",", "").isdigit()
    assert "checkpoint" in nsrm.source
    assert model_card("noop-v1").facts["training_data"].startswith("none")
    stated = model_card("nsrm-v1", {"training_data": "attributes-v2/train"})
    assert stated.facts["training_data"] == "attributes-v2/train"
    assert stated.facts["parameters"] == nsrm.facts["parameters"]
    assert model_card("someone-v3").facts["inputs"] == "not stated"
    with pytest.raises(InvalidArgument, match=r"unknown facts \['gpu'\]"):
        model_card("x-v1", {"gpu": "yes"})


def test_a_bad_board_names_the_fix(tmp_path: Path) -> None:
    (tmp_path / "b.json").write_text(json.dumps({"rows": []}))
    with pytest.raises(InvalidArgument, match=r"not a leaderboard board.*rebuild them"):
        read_boards(tmp_path)
