"""``benchmarks/`` and ``scripts/`` each list their files in their README's table: every file
of the folder is named there (itself or by its folder), every name there is a file of the
folder, and each row's pages exist and name what the row lists, so that no page quotes a
figure of a script that is gone and no script is left without a page."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("benchmarks", "scripts")
CODE = re.compile(r"`([^`]+)`")
PAGE = re.compile(r"^(?:docs/[\w./-]+\.md|reference_model/\w+/MODEL_CARD\.md)$")


def table(folder: str) -> list[list[str]]:
    """The cells of each body row of the folder's README table."""
    lines = (REPO / folder / "README.md").read_text("utf-8").splitlines()
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in lines if line.startswith("|")]
    assert len(rows) > 2 and set(rows[1][0]) <= {"-", ":"}, f"{folder}/README.md has no table"
    return rows[2:]


def named(row: list[str]) -> list[str]:
    """The files and folders (``name/``) a row's first cell names."""
    return CODE.findall(row[0])


def files(folder: str) -> list[str]:
    """Every file of the folder but its README, relative to it (caches left out)."""
    root = REPO / folder
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                  if p.is_file() and p.name != "README.md"
                  and "__pycache__" not in p.parts and p.suffix != ".pyc")


def exists(folder: str, name: str) -> bool:
    """A name of the table is a file of the folder, or (``name/``) a folder of it."""
    path = REPO / folder / name.rstrip("/")
    return path.is_dir() if name.endswith("/") else path.is_file()


def covered(path: str, names: set[str]) -> bool:
    """The file is named itself or by one of its folders."""
    parts = path.split("/")
    return path in names or any("/".join(parts[:k]) + "/" in names
                                for k in range(1, len(parts)))


@pytest.mark.parametrize("folder", FOLDERS)
def test_every_file_is_in_the_table(folder: str) -> None:
    names = {n for row in table(folder) for n in named(row)}
    missing = [f for f in files(folder) if not covered(f, names)]
    assert not missing, f"{folder}/README.md's table does not list: {missing}"


@pytest.mark.parametrize("folder", FOLDERS)
def test_every_name_in_the_table_is_in_the_folder(folder: str) -> None:
    gone = [n for row in table(folder) for n in named(row) if not exists(folder, n)]
    assert not gone, f"{folder}/README.md's table names what {folder}/ does not hold: {gone}"


@pytest.mark.parametrize("folder", FOLDERS)
def test_every_row_has_a_page_that_names_it(folder: str) -> None:
    problems = []
    for row in table(folder):
        assert len(row) == 4 and all(row), f"{folder}/README.md: a row with an empty cell: {row}"
        pages = [p for p in CODE.findall(row[2]) if PAGE.match(p)]
        if not pages:
            problems.append(f"{row[0]}: no docs page or model card named")
            continue
        problems += [f"{row[0]}: {p} is not a file" for p in pages if not (REPO / p).is_file()]
        texts = [(REPO / p).read_text("utf-8") for p in pages if (REPO / p).is_file()]
        problems += [f"{name}: none of {pages} names {folder}/{name}" for name in named(row)
                     if not any(f"{folder}/{name}" in text for text in texts)]
    assert not problems, f"{folder}/README.md:\n" + "\n".join(problems)


def test_the_tables_are_on_the_site() -> None:
    """The documentation shows both tables (``docs/hooks.py`` includes them)."""
    for folder, page in (("benchmarks", "performance.md"), ("scripts", "development.md")):
        text = (REPO / "docs" / page).read_text("utf-8")
        assert f"<!-- include: {folder}/README.md -->" in text, page
