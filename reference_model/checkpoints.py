"""Checkpoints of the learned models: one file with the config, the vocabulary and the
weights, written atomically and byte-deterministically, plus a model card (JSON).

Shipped checkpoints are package data in ``reference_model/checkpoints/<model id>.pt`` with
``<model id>.card.json`` beside them.

Every torch file is read by :func:`read_torch_file`: ``torch.load(weights_only=True)``, which
rebuilds tensors, numbers, strings and containers and nothing else, so a crafted file (a
pickle whose ``__reduce__`` calls a function) is refused instead of running code. The
project's checkpoints and resume files hold only those; :data:`SAFE_GLOBALS` is the
allow-list of the project's own types a file may hold besides (none today: a type added to
a checkpoint goes there, with a test).
"""

from __future__ import annotations

import io
import json
import os
import pickle
import re
from importlib import resources
from pathlib import Path
from typing import Any

import torch

from nsrmp_bench.errors import InvalidArgument

__all__ = ["SAFE_GLOBALS", "load_checkpoint", "read_torch_file", "save_checkpoint",
           "shipped_checkpoint", "write_card"]

FORMAT = "nsrmp-bench-checkpoint"

SAFE_GLOBALS: tuple[type, ...] = ()
"""The project's own types a checkpoint may hold besides tensors, numbers, strings and
containers (``torch.serialization.safe_globals``)."""


def read_torch_file(path: Path, what: str = "checkpoint") -> Any:
    """``torch.load`` of ``path`` with ``weights_only=True`` (on the CPU); a file that holds
    anything but tensors, numbers, strings, containers and :data:`SAFE_GLOBALS` is refused
    with :class:`InvalidArgument`, naming the file and the fix, and nothing in it runs."""
    try:
        with torch.serialization.safe_globals(list(SAFE_GLOBALS)):
            return torch.load(path, weights_only=True, map_location="cpu")
    except pickle.UnpicklingError as exc:
        found = re.search(r"Unsupported global: GLOBAL (\S+)", str(exc))
        if found is None:  # not a pickle of objects at all: bytes torch cannot parse
            said = re.search(r"WeightsUnpickler error:\s*(.+)", str(exc))
            detail = said.group(1).strip() if said else type(exc).__name__
            msg = (f"{what} {str(path)!r} cannot be read ({detail}); it is not a torch "
                   f"checkpoint: pass the .pt file a training run wrote")
            raise InvalidArgument(msg) from exc
        detail = f"it names {found.group(1)}"
        msg = (f"{what} {str(path)!r} holds objects other than tensors, numbers, strings and "
               f"containers ({detail}); it is refused because loading it could run "
               "code. Use a checkpoint written by `nsrmp-bench train` (or save_checkpoint: "
               "plain state dicts), or retrain; if the file is yours and holds a type of this "
               "project, add that type to nsrmp_bench.reference_model.checkpoints.SAFE_GLOBALS")
        raise InvalidArgument(msg) from exc


def save_checkpoint(path: Path, model_id: str, config: dict[str, Any], vocab: list[str],
                    state: dict[str, torch.Tensor], extra: dict[str, Any] | None = None) -> Path:
    """Write a checkpoint atomically (``*.tmp``, fsync, rename)."""
    payload = {"format": FORMAT, "model": model_id, "config": config, "vocab": vocab,
               "state": {k: v.detach().clone().contiguous() for k, v in sorted(state.items())},
               "extra": extra or {}}
    buf = io.BytesIO()
    torch.save(payload, buf)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        fh.write(buf.getvalue())
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def load_checkpoint(path: str | Path, model_id: str) -> dict[str, Any]:
    """Read a checkpoint, checking it is one of ``model_id``."""
    p = Path(path)
    if not p.is_file():
        msg = f"checkpoint {str(p)!r} does not exist; pass the .pt file a training run wrote"
        raise InvalidArgument(msg)
    try:
        payload: dict[str, Any] = read_torch_file(p)
    except InvalidArgument:
        raise
    except Exception as exc:
        msg = f"checkpoint {str(p)!r} cannot be read ({exc}); it is not a torch checkpoint"
        raise InvalidArgument(msg) from exc
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        msg = (f"{str(p)!r} is not an nsrmp-bench checkpoint; pass best.pt from a training "
               "run's output directory")
        raise InvalidArgument(msg)
    if payload.get("model") != model_id:
        msg = (f"checkpoint {str(p)!r} is of model {payload.get('model')!r}, not {model_id!r}; "
               f"pass a checkpoint of {model_id}")
        raise InvalidArgument(msg)
    return payload


def shipped_checkpoint(model_id: str) -> Path:
    """The checkpoint shipped inside the package for ``model_id``."""
    ref = resources.files("nsrmp_bench.reference_model").joinpath("checkpoints", f"{model_id}.pt")
    path = Path(str(ref))
    if not path.is_file():
        msg = (f"no checkpoint of {model_id} is shipped with this installation ({path}); "
               "train one with `nsrmp-bench train` and pass --checkpoint")
        raise InvalidArgument(msg)
    return path


def write_card(path: Path, card: dict[str, Any]) -> Path:
    """Write a model card as sorted, indented JSON."""
    path.write_text(json.dumps(card, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return path
