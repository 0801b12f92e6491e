"""Contact sheets and the ``show`` verb (through the storage API)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

from world_scenes import determinism_cases, symbolic_episode  # noqa: E402

from nsrmp_bench.episode import Episode  # noqa: E402
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.generators.world.contact_sheet import contact_sheet, step_caption  # noqa: E402
from nsrmp_bench.generators.world.realise import realise  # noqa: E402

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def episode(world: Any) -> Episode:
    scene, states, steps = determinism_cases()["stack"]
    sym = symbolic_episode(scene, states, steps, "sheet-test-0")
    return Episode(sym, realise(scene, states, steps, world))


def test_the_sheet_has_one_panel_per_state_and_the_boxes_drawn(episode: Episode) -> None:
    img = contact_sheet(episode, scale=2, columns=3)
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert img.shape[1] == 3 * (640 + 8) + 8  # three 2x panels side by side
    plain = contact_sheet(episode, scale=1, columns=1)
    assert plain.shape[0] > 3 * 240  # three states stacked
    # the panel shows the rendered image where no box or label is drawn
    rgb = episode.rendering.observations.rgb[0]  # type: ignore[union-attr]
    assert step_caption(episode, 1) == "top(1 blue cube -> 0 red lego)"
    assert step_caption(episode, 2) == "top(2 white dice -> 1 blue cube)"
    col = plain[:, 8:328]
    # find the first panel: the rows that equal the rendered image outside the boxes
    rows = [r for r in range(col.shape[0] - 240) if np.array_equal(col[r, :40], rgb[0, :40])]
    assert rows, "the initial image is not on the sheet"


def test_a_sheet_needs_images(episode: Episode) -> None:
    with pytest.raises(InvalidArgument, match="no images"):
        contact_sheet(Episode(episode.symbolic, None))


def test_show_writes_the_sheet_of_a_stored_episode(episode: Episode, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    storage = pytest.importorskip("nsrmp_bench.storage")
    from nsrmp_bench.cli.main import main

    record = storage.write_shard(tmp_path / "data", 0, [episode], split="world-test/test")
    shard = tmp_path / "data" / record.file
    out = tmp_path / "sheets" / "sheet.png"
    assert main(["show", str(shard), "--png", str(out), "--episode", "sheet-test-0"]) == 0
    assert "sheet-test-0" in capsys.readouterr().out
    written = cv2.imread(str(out))[:, :, ::-1]
    assert np.array_equal(written, contact_sheet(episode))
    assert main(["show", str(shard), "--png", str(tmp_path / "x.jpg")]) == 2
    assert "must name a .png" in capsys.readouterr().err
    assert main(["show", str(shard), "--png", str(out), "--episode", "5"]) == 2
    assert "out of range" in capsys.readouterr().err
