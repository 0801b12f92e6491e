"""The data dictionary of the documentation (``docs/data.md``) is the shard's real layout: every attribute and dataset of
a freshly generated smoke-v2 episode has a row, every row (but the robot-only ones, which
a teleport episode lacks) is in the episode, and each row's dtype and rank are the stored
ones."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import h5py
import numpy as np

README = Path(__file__).resolve().parents[2] / "docs" / "data.md"
DTYPES = {"string": "O", "bool": "bool", "int16": "int16", "int64": "int64", "uint8": "uint8",
          "float32": "float32", "float64": "float64"}


def dictionary() -> dict[str, tuple[str, str]]:
    """field -> (type cell, what-it-is cell) of the data page's table."""
    text = README.read_text("utf-8")
    table = text[text.index("<!-- data-dictionary:begin -->"):
                 text.index("<!-- data-dictionary:end -->")]
    rows = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[0].startswith("`"):
            rows[cells[0].strip("`")] = (cells[1], cells[4])
    return rows


def stored(group: h5py.Group) -> dict[str, Any]:
    """Every attribute (``@name``, ``sub/@name``) and dataset of an episode group."""
    out: dict[str, Any] = {f"@{k}": v for k, v in group.attrs.items()}

    def visit(name: str, obj: Any) -> None:
        if isinstance(obj, h5py.Dataset):
            out[name] = obj
        else:
            out.update({f"{name}/@{k}": v for k, v in obj.attrs.items()})

    group.visititems(visit)
    return out


def _kind(value: Any) -> tuple[str, int]:
    if isinstance(value, h5py.Dataset):
        if value.dtype.kind in "OS" or h5py.check_string_dtype(value.dtype) is not None:
            return "string", value.ndim
        return str(value.dtype), value.ndim
    if isinstance(value, str | bytes):
        return "string", 0
    return str(np.asarray(value).dtype), 0


def test_the_readme_dictionary_matches_a_generated_episode(smoke_v2_test: Path) -> None:
    rows = dictionary()
    shard = sorted(smoke_v2_test.glob("*.h5"))[0]
    with h5py.File(shard, "r") as f:
        group = f["data"][sorted(f["data"])[0]]
        fields = stored(group)
        optional = {k for k, (_, what) in rows.items() if what.startswith("robot episodes only")}
        assert set(fields) == set(rows) - optional, (
            f"missing from docs/data.md: {sorted(set(fields) - set(rows))}; "
            f"in docs/data.md but not stored: {sorted(set(rows) - optional - set(fields))}")
        for name, value in fields.items():
            kind, ndim = _kind(value)
            cell = rows[name][0]
            assert cell.split()[0] == kind, (name, cell, kind)
            shape = re.search(r"\((.*)\)", cell)
            if kind != "string":
                dims = [d for d in shape.group(1).split(",") if d.strip()] if shape else []
                assert len(dims) == ndim, (name, cell, ndim)
