"""The committed site is recomputable: its pages rebuild from the committed boards, entries
and runs to the same bytes; model cards come from checkpoint cards, the baseline registry
or the entry, and a card without facts says so; ranks are shared by the stated rule; the
index names the best non-reference entry and keeps the smoke test board apart; every link
stays inside the site folder or reaches the committed predictions files beside it
(``leaderboards/predictions/``, never copied into the site); a site written away from them
carries its own copies."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest
from site_build import SITE, build_site, mirror

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import load_entries
from nsrmp_bench.results.model_cards import model_card
from nsrmp_bench.results.site import RANK_RULE, read_boards, shared_ranks, write_site


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


def _row(entry: str, iou_m: tuple[float, float, float] | None, kind: str = "reference"
         ) -> dict[str, object]:
    return {"entry": entry, "model": entry, "kind": kind,
            "metrics": {"iou_m": list(iou_m) if iou_m else [None, None, None]}}


def test_ranks_are_shared_where_intervals_overlap_the_leader_of_the_tie() -> None:
    rows = [_row("oracle", (1.0, 1.0, 1.0), "baseline"),
            _row("a", (0.50, 0.45, 0.55)),
            _row("b", (0.48, 0.44, 0.52)),    # overlaps a: shares 1
            _row("c", (0.40, 0.36, 0.44)),    # overlaps b, not a (the leader): 3
            _row("d", (0.39, 0.35, 0.43)),    # overlaps c, its leader: 3=
            _row("noop", (0.01, 0.0, 0.02), "baseline"),
            _row("e", (0.30, 0.28, 0.32)),
            _row("f", None)]
    assert shared_ranks(rows) == ["", "1=", "1=", "3=", "3=", "", "5", "6"]
    assert "overlaps" in RANK_RULE and "not ranked" in RANK_RULE


def test_committed_boards_rank_the_paper_tie_together() -> None:
    rows = read_boards(SITE.parent)["paper-v2/test"]
    ranks = dict(zip((r["model"] for r in rows), shared_ranks(rows), strict=True))
    assert ranks["oracle-v1"] == "" and ranks["noop-v1"] == ""
    # nsrm-v2, nsrm-v3 and nsrm-v4 lead, tied by the rule (v3's and v4's intervals overlap
    # v2's: they predict v2's programs on the templates but where the size calibration
    # rescales a scene or v4's reader abstains);
    # on classical-v1 boxes nsrm-v2 shares first place exactly when its interval reaches
    # the leader's (0.828 [0.817, 0.838] against 0.865 [0.854, 0.875] on the committed
    # boards: it does not); NMN+ v4 leads NMN+ v2 and v3 (0.764, tied exactly: no
    # calibration), which share its rank
    iou = {r["model"]: r["metrics"]["iou_m"] for r in rows}
    assert iou["nsrm-v3"][2] >= iou["nsrm-v2"][1] and iou["nmn-v3"] == iou["nmn-v2"]
    shared = iou["nsrm-v2+classical-v1"][2] >= iou["nsrm-v2"][1]
    assert ranks["nsrm-v2"] == ranks["nsrm-v3"] == ranks["nsrm-v4"] == "1="
    assert ranks["nsrm-v2+classical-v1"] == ("1=" if shared else "4")
    assert ranks["nmn-v4"] == ranks["nmn-v2"] == ranks["nmn-v3"] == "5="
    assert ranks["nmn-v1"] == ranks["nsrm-v1"] and ranks["nsrm-v1"].endswith("=")


def _links(page: Path) -> list[str]:
    return re.findall(r'(?:href|src)="([^"]+)"', page.read_text("utf-8"))


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_site(tmp_path_factory.mktemp("pages"), figures=False)


def test_every_link_stays_inside_the_site_or_reaches_the_committed_predictions(
        pages: Path) -> None:
    predictions = pages.parent / "predictions"
    reached = set()
    for page in [*pages.glob("*.html"), *pages.glob("cards/*.html")]:
        for link in _links(page):
            assert "://" not in link, (page.name, link)
            target = Path(os.path.normpath(page.parent / link))
            if target.is_relative_to(predictions):
                reached.add(target.name)
            else:
                assert target.is_relative_to(pages), (
                    f"{page.name} links {link}, outside the site and leaderboards/predictions/")
            assert target.is_file() and not target.is_symlink(), (page.name, link)
    entries = load_entries(pages.parent / "entries")
    assert reached == {e.predictions.name for e in entries}
    assert not (pages / "predictions").exists(), "the site copies the predictions files"
    assert not (SITE / "predictions").exists(), (
        "leaderboards/site/predictions/ holds copies: delete it and rebuild with "
        "`nsrmp-bench leaderboard --site-only`")


def test_a_site_written_away_from_the_predictions_carries_copies(tmp_path: Path) -> None:
    boards_dir = mirror(tmp_path)
    entries = load_entries(boards_dir / "entries")
    away = tmp_path / "publish" / "site"
    write_site(read_boards(boards_dir), entries, away)
    board = (away / "smoke-v2-test.html").read_text("utf-8")
    entry = next(e for e in entries if e.split == "smoke-v2/test")
    assert f'href="predictions/{entry.predictions.name}"' in board
    assert (away / "predictions" / entry.predictions.name).read_bytes() == \
        entry.predictions.read_bytes()


def test_the_index_names_the_best_non_reference_entry_and_keeps_smoke_apart(
        pages: Path) -> None:
    index = (pages / "index.html").read_text("utf-8")
    main, _, tests = index.partition("<h2>Test boards</h2>")
    assert 'data-split="smoke-v2/test"' in tests and 'data-split="smoke-v2/test"' not in main
    for row in re.findall(r'<tr data-split="([^"]+)">(.*?)</tr>', index):
        best = re.findall(r"<td[^>]*>(.*?)</td>", row[1])[2]
        assert "oracle" not in best and "noop" not in best, row
    assert "shares rank 1 with" in main
    smoke = (pages / "smoke-v2-test.html").read_text("utf-8")
    assert "<h1>Test board: smoke-v2/test</h1>" in smoke


def test_the_board_has_a_protocol_column_and_filter(pages: Path) -> None:
    board = (pages / "paper-v2-test.html").read_text("utf-8")
    assert '<th data-type="text">protocol</th>' in board
    assert "detected boxes (detector-v1)" in board and "detected boxes (classical-v1)" in board
    assert re.search(r'data-entry="paper-v2-test--dense-v1" data-protocol="dense"', board)
    for protocol in ("gold boxes", "detected boxes", "dense"):
        assert f'data-filter="protocol" value="{protocol}"' in board


def test_a_card_without_facts_says_so(tmp_path: Path) -> None:
    boards_dir = mirror(tmp_path)
    entry = boards_dir / "entries" / "smoke-v2-test--someone-v1.json"
    entry.write_text(json.dumps({"model": "someone-v1", "split": "smoke-v2/test",
                                 "predictions": "../predictions/smoke-v2-test--oracle-v1.jsonl.gz",
                                 "kind": "submission"}))
    boards = read_boards(boards_dir)
    boards["smoke-v2/test"].append({**boards["smoke-v2/test"][0], "entry": entry.stem,
                                    "model": "someone-v1", "kind": "submission"})
    write_site(boards, load_entries(boards_dir / "entries"), tmp_path / "site")
    card = (tmp_path / "site" / "cards" / f"{entry.stem}.html").read_text("utf-8")
    assert "card gives no facts" in card and "Facts from nothing stated" not in card
    assert "<dl" not in card
    known = (tmp_path / "site" / "cards" / "smoke-v2-test--nsrm-v1.html").read_text("utf-8")
    assert "gives no facts" not in known and "<dl" in known


def test_a_model_on_detected_boxes_has_its_model_card() -> None:
    card = model_card("nsrm-v1+detector-v1")
    assert card.facts["parameters"] == model_card("nsrm-v1").facts["parameters"]
    assert card.facts["inputs"].endswith("here the boxes detector-v1 detected instead of the "
                                         "gold boxes")
    assert model_card("someone-v1+detector-v1").source == "nothing stated"
