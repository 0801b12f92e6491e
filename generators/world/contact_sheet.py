"""Contact sheets: one picture that shows an episode was carried out.

:func:`contact_sheet` draws the instruction on top, then one panel per rendered state
(the initial scene, the scene after each step; the last panel is the final scene), each
object's amodal box and index on every panel, the grounded step under each panel (e.g.
``top(3 yellow cube -> 1 red lego)``) with the moved object's box drawn thicker, and a
legend of the object indices. Drawing uses OpenCV; the result is an RGB uint8 array.
"""

from __future__ import annotations

import textwrap
from types import ModuleType
from typing import Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument

__all__ = ["contact_sheet", "step_caption"]

_PALETTE: Final = (
    (230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48),
    (145, 30, 180), (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212),
    (0, 128, 128), (220, 190, 255), (170, 110, 40), (255, 250, 200), (128, 0, 0),
)
_INK: Final = (20, 20, 20)
_PAPER: Final = (250, 250, 250)
_FONT_SCALE: Final = 0.5


def step_caption(episode: Episode, k: int) -> str:
    """Caption of the panel after step ``k`` (1-based), e.g. ``top(3 red cube -> 1 blue dice)``."""
    objects = episode.symbolic.scene.objects
    g = episode.symbolic.grounded[k - 1]
    return (f"{g.action}({g.subject} {objects[g.subject].label} -> "
            f"{g.reference} {objects[g.reference].label})")


def _text_block(cv2: ModuleType, lines: list[str], width: int, scale: float,
                thickness: int = 1) -> NDArray[np.uint8]:
    (_, th), base = cv2.getTextSize("Ag", cv2.FONT_HERSHEY_SIMPLEX, scale, thickness)
    line_h = th + base + 6
    img = np.full((line_h * len(lines) + 8, width, 3), _PAPER, dtype=np.uint8)
    for i, line in enumerate(lines):
        cv2.putText(img, line, (8, 4 + th + i * line_h), cv2.FONT_HERSHEY_SIMPLEX, scale,
                    _INK, thickness, cv2.LINE_AA)
    return img


def _wrap(cv2: ModuleType, text: str, width: int, scale: float) -> list[str]:
    (cw, _), _ = cv2.getTextSize("m", cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    chars = max(10, int((width - 16) / max(cw * 0.85, 1)))
    return textwrap.wrap(text, chars) or [""]


def _panel(cv2: ModuleType, episode: Episode, k: int, scale: int) -> NDArray[np.uint8]:
    assert episode.rendering is not None and episode.rendering.observations is not None
    obs = episode.rendering.observations
    tg = episode.rendering.targets
    img = np.ascontiguousarray(obs.rgb[k])
    h, w = img.shape[:2]
    img = cv2.resize(img, (w * scale, h * scale), interpolation=cv2.INTER_NEAREST)
    moved = episode.symbolic.grounded[k - 1].subject if k > 0 else -1
    reference = episode.symbolic.grounded[k - 1].reference if k > 0 else -1
    for i in range(tg.boxes_amodal.shape[1]):
        colour = _PALETTE[i % len(_PALETTE)]
        x0, y0, x1, y1 = (float(v) * scale for v in tg.boxes_amodal[k, i])
        thick = 3 if i == moved else 1
        cv2.rectangle(img, (round(x0), round(y0)), (round(x1) - 1, round(y1) - 1), colour,
                      thick, cv2.LINE_AA)
        if i == reference:
            cv2.rectangle(img, (round(x0) - 3, round(y0) - 3), (round(x1) + 2, round(y1) + 2),
                          colour, 1, cv2.LINE_AA)
        label = str(i)
        (tw, th), base = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, _FONT_SCALE, 1)
        lx, ly = round(x0), max(round(y0) - th - base - 2, 0)
        cv2.rectangle(img, (lx, ly), (lx + tw + 4, ly + th + base + 2), colour, -1)
        light = sum(colour) > 450
        cv2.putText(img, label, (lx + 2, ly + th + 1), cv2.FONT_HERSHEY_SIMPLEX, _FONT_SCALE,
                    _INK if light else _PAPER, 1, cv2.LINE_AA)
    trajectory = episode.rendering.trajectory
    if trajectory is not None and k > 0:  # the end-effector path of the step that led here
        from nsrmp_bench.generators.robot.path import draw_ee_path

        img = draw_ee_path(img, episode.rendering.camera, trajectory, step=k - 1, scale=scale)
    steps = episode.symbolic.num_steps
    title = "initial scene" if k == 0 else f"after step {k}" + (" (final)" if k == steps else "")
    caption = "" if k == 0 else step_caption(episode, k)
    lines = [title] + (_wrap(cv2, caption, img.shape[1], _FONT_SCALE) if caption else [" "])
    text = _text_block(cv2, lines, img.shape[1], _FONT_SCALE)
    out: NDArray[np.uint8] = np.concatenate([img, text], axis=0)
    return out


def contact_sheet(episode: Episode, *, scale: int = 2, columns: int = 3) -> NDArray[np.uint8]:
    """The contact sheet of ``episode`` as an RGB uint8 image ``(H, W, 3)``.

    ``scale`` enlarges the images (nearest neighbour) so that labels stay legible;
    ``columns`` is the number of panels per row.
    """
    cv2 = require("cv2")
    if episode.rendering is None or episode.rendering.observations is None:
        msg = (f"episode {episode.id} has no images to draw; read it with images "
               "(e.g. collection.episode(i, images=True)) or realise it first")
        raise InvalidArgument(msg)
    if scale < 1 or columns < 1:
        msg = f"contact_sheet needs scale >= 1 and columns >= 1, got {scale} and {columns}"
        raise InvalidArgument(msg)
    states = episode.rendering.observations.rgb.shape[0]
    panels = [_panel(cv2, episode, k, scale) for k in range(states)]
    ph = max(p.shape[0] for p in panels)
    pw = max(p.shape[1] for p in panels)
    cols = min(columns, len(panels))
    rows = -(-len(panels) // cols)
    gap = 8
    grid = np.full((rows * (ph + gap), cols * (pw + gap) + gap, 3), _PAPER, dtype=np.uint8)
    for n, panel in enumerate(panels):
        r, c = divmod(n, cols)
        y, x = r * (ph + gap), gap + c * (pw + gap)
        grid[y:y + panel.shape[0], x:x + panel.shape[1]] = panel
    width = grid.shape[1]
    sym = episode.symbolic
    header = [f"{sym.id}  ({sym.num_objects} objects, {sym.num_steps} steps, "
              f"{sym.instruction.phrasing}, template {sym.instruction.template_id})"]
    header += _wrap(cv2, f'"{sym.instruction.text}"', width, 0.7)
    top = _text_block(cv2, header, width, 0.7, thickness=1)
    legend = ", ".join(f"{i}: {o.label}" for i, o in enumerate(sym.scene.objects))
    bottom = _text_block(cv2, _wrap(cv2, "objects  " + legend, width, _FONT_SCALE), width,
                         _FONT_SCALE)
    out: NDArray[np.uint8] = np.concatenate([top, grid, bottom], axis=0)
    return out
