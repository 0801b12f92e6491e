"""Checkpoints and resume files load with ``weights_only=True``: a crafted file whose pickle
would call a function (here: create a file) is refused with an error that names the file and
the fix, and the function never runs; every shipped checkpoint loads as it is."""

from __future__ import annotations

from pathlib import Path

import pytest

torch = pytest.importorskip("torch")

from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.reference_model.checkpoints import (  # noqa: E402
    FORMAT,
    load_checkpoint,
    read_torch_file,
)
from nsrmp_bench.reference_model.registry import MODELS  # noqa: E402


class _Touch:
    """Unpickled by a full ``torch.load``, it creates ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        return (open, (str(self.marker), "w"))


def _crafted(tmp_path: Path) -> tuple[Path, Path]:
    marker = tmp_path / "ran.txt"
    path = tmp_path / "best.pt"
    torch.save({"format": FORMAT, "model": "nsrm-v2", "config": {}, "vocab": [],
                "state": {}, "extra": {"payload": _Touch(marker)}}, path)
    return path, marker


def test_a_crafted_checkpoint_is_refused_and_runs_nothing(tmp_path: Path) -> None:
    path, marker = _crafted(tmp_path)
    with pytest.raises(InvalidArgument) as caught:
        load_checkpoint(path, "nsrm-v2")
    text = str(caught.value)
    assert str(path) in text and "could run code" in text
    assert "nsrmp-bench train" in text and "SAFE_GLOBALS" in text  # the fix
    assert not marker.exists()


def test_a_crafted_resume_file_is_refused(tmp_path: Path) -> None:
    path, marker = _crafted(tmp_path)
    with pytest.raises(InvalidArgument, match=r"resume file .*best\.pt.*could run code"):
        read_torch_file(path, "resume file")
    assert not marker.exists()


def test_every_shipped_checkpoint_loads_safely() -> None:
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint

    for entry in MODELS.values():
        try:
            path = shipped_checkpoint(entry.id)
        except InvalidArgument:
            continue  # a model without a shipped checkpoint
        payload = load_checkpoint(path, entry.id)
        assert payload["state"], entry.id


def test_training_resumes_from_its_own_resume_file(tmp_path: Path) -> None:
    from torch import nn

    from nsrmp_bench.reference_model.training import CHECKPOINT, Stage, train_stages

    torch.manual_seed(0)
    net = nn.Linear(2, 1)
    x = torch.randn(8, 2)

    def stage(epochs: int) -> Stage:
        return Stage("main", epochs, torch.arange(8), lambda: list(net.parameters()),
                     lambda rows: net(x[rows]).pow(2).mean(), 0.1, 4, uses_splitter=True)

    first = train_stages(net, [stage(1)], tmp_path, seed=0, validate=lambda s: 0.0,
                         on_best=lambda: None, quiet=True)
    assert (tmp_path / CHECKPOINT).is_file() and first.stage == 1
    again = train_stages(net, [stage(1)], tmp_path, seed=0, validate=lambda s: 0.0,
                         on_best=lambda: None, quiet=True)  # read with weights_only=True
    assert again.stage == 1 and again.best == first.best


def test_a_file_that_is_no_checkpoint_says_so(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(InvalidArgument, match=r"cannot be read .*not a torch checkpoint"):
        load_checkpoint(bad, "nsrm-v2")
