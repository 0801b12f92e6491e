"""An EvalAI annotation file holds one part's plain file names: a member that names a
folder, climbs out or hides is refused before anything is unpacked."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from nsrmp_bench.errors import UnsafePath
from nsrmp_bench.evalai import evaluate_in_process

PHASES = {"public-test": {"split_codename": "public_test", "part": "smoke-v2/test",
                          "manifest_root_hash": "ab" * 32}}


@pytest.mark.parametrize("member", ["../../escaped.txt", "/tmp/absolute.txt", "sub/x.h5",
                                    ".hidden", "..\\x.h5"])
def test_an_annotation_member_outside_its_folder_is_refused(tmp_path: Path, member: str) -> None:
    annotation = tmp_path / f"evil-{abs(hash(member))}.zip"
    with zipfile.ZipFile(annotation, "w") as z:
        z.writestr("manifest.json", "{}")
        z.writestr(member, "x")
    with pytest.raises(UnsafePath, match=r"is not a plain file name"):
        evaluate_in_process(annotation, tmp_path / "p.jsonl", "public-test", PHASES)
    assert not (tmp_path.parent / "escaped.txt").exists()
