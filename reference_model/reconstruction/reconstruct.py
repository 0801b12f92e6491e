"""``reconstruct``: images of the predicted sub-goal states of any predictions file, scored
with SSIM against the simulator's renders.

For every record with ``step_boxes`` the renderer (the network, or PyBullet for the
reference row) makes the image after each predicted step, starting from the episode's
initial image and initial boxes; the network chains its own outputs. Gold step ``k`` is
compared with the predicted state ``min(k, S_pred)`` (a plan with fewer steps is scored by
the last image it reached, the initial image if it has none; extra predicted steps are
drawn, not scored). Per gold step: SSIM over the whole image and SSIM inside the region,
the union of the gold boxes (before and after the step) of the objects the gold step moved
and the predicted boxes (before and after) of those the aligned predicted step moved.

Writes into ``out``: ``images/<id>/step-<j>.png`` per predicted step, ``sheets/<id>.png``
per episode (the initial image, then reconstructed and gold per step) and ``ssim.json``
(the summary, per step index, per step of every episode).
"""

from __future__ import annotations

import json
import math
import re
import textwrap
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.reconstruction.inputs import box_mask, moved_objects
from nsrmp_bench.reference_model.reconstruction.ssim import ssim_scores
from nsrmp_bench.storage.atomic import atomic_write_bytes, atomic_write_text

if TYPE_CHECKING:
    from nsrmp_bench.episode import Episode
    from nsrmp_bench.scoring.submission import Submission

__all__ = ["RENDERERS", "StepScore", "reconstruct_file", "summarise"]

RENDERERS = ("network", "sim")
U8 = NDArray[np.uint8]


@dataclass(frozen=True)
class StepScore:
    """The SSIM of one gold step of one episode."""

    id: str
    step: int  # gold step, 1-based
    steps: int  # gold steps of the episode
    predicted_step: int  # the predicted state it is compared with (0: the initial image)
    whole: float
    region: float


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name)


def _write_png(path: Path, rgb: U8) -> None:
    cv2 = require("cv2")
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    if not ok:
        msg = f"could not encode {path} as PNG"
        raise InvalidArgument(msg)
    atomic_write_bytes(path, bytes(buf))


def _label(cv2: ModuleType, image: U8, text: str) -> U8:
    bar = np.full((18, image.shape[1], 3), 250, np.uint8)
    cv2.putText(bar, text, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (20, 20, 20), 1,
                cv2.LINE_AA)
    return np.concatenate([bar, image], axis=0)


def sheet(instruction: str, initial: U8, predicted: list[U8], gold: list[U8],
          scores: list[StepScore]) -> U8:
    """The contact sheet: the initial image and the instruction, then per gold step the
    reconstructed image (of the predicted state it is compared with) and the gold render."""
    cv2 = require("cv2")
    blank = np.full_like(initial, 250)
    for i, line in enumerate(textwrap.wrap(instruction, 52)[:12]):
        cv2.putText(blank, line, (6, 20 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.42,
                    (20, 20, 20), 1, cv2.LINE_AA)
    rows = [np.concatenate([_label(cv2, initial, "initial"),
                            _label(cv2, blank, "instruction")], axis=1)]
    for s in scores:
        rec = predicted[s.predicted_step - 1] if s.predicted_step > 0 else initial
        rows.append(np.concatenate([
            _label(cv2, rec, f"step {s.step}: reconstructed  SSIM {s.whole:.3f}, "
                             f"region {s.region:.3f}"),
            _label(cv2, gold[s.step - 1], f"step {s.step}: gold render")], axis=1))
    out: U8 = np.concatenate(rows, axis=0)
    return out


def _region(gold_boxes: NDArray[Any], pred_states: NDArray[Any], k: int, j: int,
            h: int, w: int) -> NDArray[np.bool_]:
    """The pixels of step ``k``'s region (see the module doc) for predicted state ``j``."""
    boxes = []
    g = moved_objects(gold_boxes[k - 1], gold_boxes[k])
    boxes += [gold_boxes[k - 1][g], gold_boxes[k][g]]
    if j == k:
        p = moved_objects(pred_states[k - 1], pred_states[k])
        boxes += [pred_states[k - 1][p], pred_states[k][p]]
    return box_mask(np.concatenate(boxes).reshape(-1, 4), h, w)


def summarise(scores: list[StepScore]) -> dict[str, Any]:
    """Mean SSIMs overall, per step index and per episode length."""
    def mean(vals: list[float]) -> float | None:
        v = [x for x in vals if not math.isnan(x)]
        return round(float(np.mean(v)), 4) if v else None

    def block(sel: list[StepScore]) -> dict[str, Any]:
        return {"steps": len(sel), "whole": mean([s.whole for s in sel]),
                "region": mean([s.region for s in sel])}

    by_step = sorted({s.step for s in scores})
    by_len = sorted({s.steps for s in scores})
    return {
        **block(scores),
        "episodes": len({s.id for s in scores}),
        "by_step": {str(k): block([s for s in scores if s.step == k]) for k in by_step},
        "by_episode_steps": {str(n): block([s for s in scores if s.steps == n])
                             for n in by_len},
        "final_state": block([s for s in scores if s.step == s.steps]),
    }


def _records(sub: Submission) -> list[tuple[int, NDArray[Any], NDArray[Any] | None]]:
    """Per record: its index, its step boxes (S, N, 4) and positions (N, 3) or None."""
    out = []
    for r in range(len(sub)):
        n = int(sub.n_objects[r])
        sb = sub.step_boxes[sub.stepbox_offsets[r]:sub.stepbox_offsets[r + 1]]
        steps = sb.reshape(int(sub.n_step_states[r]), n, 4)
        pos = (sub.positions[sub.obj_offsets[r]:sub.obj_offsets[r + 1]]
               if bool(sub.has_positions[r]) else None)
        out.append((r, steps, pos))
    return out


def reconstruct_file(predictions: str | Path, data: str | Path, out: str | Path, *,
                     renderer: str = "network", checkpoint: str | Path | None = None,
                     limit: int = 0, images: bool = True,
                     progress: Callable[[int, int], None] | None = None,
                     sim_renderer: Callable[[], Any] | None = None) -> dict[str, Any]:
    """Reconstruct and score every record (the first ``limit``; 0: all); returns the
    JSON written to ``out/ssim.json``. ``renderer="sim"`` renders with ``sim_renderer()``
    (``generators.world.sim_renderer.SimRenderer``: the models do not import the
    generators, the caller passes it)."""
    from nsrmp_bench.scoring.align import split_matches
    from nsrmp_bench.scoring.reader import read_submission
    from nsrmp_bench.storage import open as open_storage
    from nsrmp_bench.storage.split_root import part_of_split

    if renderer not in RENDERERS:
        msg = f"--renderer {renderer!r} is not one of {', '.join(RENDERERS)}"
        raise InvalidArgument(msg)
    if limit < 0:
        msg = f"--limit must be 0 (all) or a positive number of episodes, got {limit}"
        raise InvalidArgument(msg)
    sub = read_submission(predictions)
    if not bool(np.any(sub.has_step_boxes)):
        msg = (f"{predictions}: no line has step_boxes (the boxes after each step); "
               "reconstruction needs them: write them (the oracle's, NSRM's and "
               "write_model_predictions' files have them)")
        raise InvalidArgument(msg)
    collection = open_storage(data, part=part_of_split(sub.header.split))
    split = getattr(collection, "split", None)
    if split and not split_matches(sub.header.split, split):
        collection.close()
        msg = (f"{predictions}: the header says split {sub.header.split!r} but {data} holds "
               f"split {split!r}; pass that split's data with --data")
        raise InvalidArgument(msg)
    render: Callable[[Episode, NDArray[Any], NDArray[Any] | None], list[U8]]
    sim = None
    if renderer == "sim":
        if sim_renderer is None:
            msg = ("renderer 'sim' needs the PyBullet renderer: pass sim_renderer="
                   "nsrmp_bench.generators.world.sim_renderer.SimRenderer (the CLI does)")
            raise InvalidArgument(msg)
        sim = sim_renderer()
        render = sim.chain
    else:
        from nsrmp_bench.dataset import EpisodeDataset
        from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint
        from nsrmp_bench.reference_model.reconstruction import (
            MODEL_ID,
            ReconstructionPredictor,
        )

        net = ReconstructionPredictor.from_checkpoint(
            checkpoint if checkpoint is not None else shipped_checkpoint(MODEL_ID))
        items = EpisodeDataset(collection)  # the network reads each episode's inputs

        def render(ep: Episode, steps: NDArray[Any], _pos: NDArray[Any] | None) -> list[U8]:
            return net.reconstruct(items[collection.position(ep.id)], steps)

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    known = set(collection.ids)
    records = _records(sub)
    if limit:
        records = records[:limit]
    scores: list[StepScore] = []
    t0 = time.perf_counter()
    n_images = 0
    try:
        for done, (r, steps, positions) in enumerate(records):
            eid = sub.ids[r]
            if eid not in known:
                msg = (f"{predictions} {sub.where(r)}: id {eid!r} is not an episode of "
                       f"{data}; pass the data of split {sub.header.split!r}")
                raise InvalidArgument(msg)
            ep = collection.get(eid, images=True)
            rend = ep.rendering
            if rend is None or rend.observations is None:
                msg = f"episode {eid} in {data} has no images to compare with"
                raise InvalidArgument(msg)
            gold_rgb = rend.observations.rgb
            gold_boxes = np.asarray(rend.targets.boxes_amodal, np.float64)
            if steps.shape[1] != gold_boxes.shape[1]:
                msg = (f"{predictions} {sub.where(r)}: {steps.shape[1]} objects per step for "
                       f"episode {eid}, which has {gold_boxes.shape[1]}")
                raise InvalidArgument(msg)
            pred = render(ep, steps, positions) if len(steps) else []
            n_images += len(pred)
            states = np.concatenate([gold_boxes[:1], steps]) if len(steps) else gold_boxes[:1]
            h, w = gold_rgb.shape[1:3]
            ep_scores = []
            for k in range(1, gold_rgb.shape[0]):
                j = min(k, len(pred))
                image = pred[j - 1] if j > 0 else gold_rgb[0]
                region = _region(gold_boxes, states, k, j, h, w)
                whole, inside = ssim_scores(image, gold_rgb[k], region)
                ep_scores.append(StepScore(eid, k, gold_rgb.shape[0] - 1, j, whole, inside))
            scores += ep_scores
            if images:
                for j, img in enumerate(pred, start=1):
                    _write_png(out / "images" / _safe(eid) / f"step-{j}.png", img)
                _write_png(out / "sheets" / f"{_safe(eid)}.png",
                           sheet(ep.symbolic.instruction.text, gold_rgb[0], pred,
                                 list(gold_rgb[1:]), ep_scores))
            if progress is not None:
                progress(done + 1, len(records))
    finally:
        collection.close()
        if sim is not None:
            sim.close()
    seconds = time.perf_counter() - t0
    result = {
        "predictions": str(predictions), "data": str(data), "split": sub.header.split,
        "model": sub.header.model, "renderer": renderer,
        "reconstruction": ("reconstruction-v1 " + (str(checkpoint) if checkpoint else
                                                   "(shipped checkpoint)"))
        if renderer == "network" else "pybullet",
        "ssim": "skimage.metrics.structural_similarity, 7x7 uniform window, data range 255",
        "seconds": round(seconds, 2), "images": n_images,
        "summary": summarise(scores),
        "steps": [asdict(s) for s in scores],
    }
    atomic_write_text(out / "ssim.json", json.dumps(result, indent=1) + "\n")
    return result


def table(result: dict[str, Any]) -> str:
    """The summary as a text table (overall, per step index, final state)."""
    s = result["summary"]
    lines = [f"{result['split']}  predictions of {result['model']}  renderer "
             f"{result['renderer']}  ({s['episodes']} episodes, {s['steps']} steps)",
             f"{'':16}{'steps':>7}{'SSIM':>8}{'region':>8}"]

    def row(name: str, b: dict[str, Any]) -> str:
        def f(v: float | None) -> str:
            return "-" if v is None else f"{v:.3f}"
        return f"{name:16}{b['steps']:>7}{f(b['whole']):>8}{f(b['region']):>8}"

    lines.append(row("all steps", s))
    for k, b in s["by_step"].items():
        lines.append(row(f"step {k}", b))
    lines.append(row("final state", s["final_state"]))
    return "\n".join(lines)
