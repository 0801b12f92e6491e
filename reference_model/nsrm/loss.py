"""NSRM's loss: the box loss of a predicted final world against the gold final boxes.

Per object: the L1 distance of the pixel corners (in units of 40 px) plus ``1 - IoU``; the
loss of a row is the sum over its real objects (so moving the wrong object costs the same
in a scene of 3 or 15). It is the paper's ``sum ||loc - loc*|| + beta (1 - IoU)`` with the
distance in pixels, not squared, over every object (``reference/nsrm-original-model.md``
§1.8). Depth is not supervised: the final boxes are the supervision.
"""

from __future__ import annotations

import torch
from torch import Tensor

__all__ = [
    "box_loss",
    "execution_loss",
    "identification_loss",
    "mover_and_base",
    "simulator_loss",
    "world_to_boxes",
]


def world_to_boxes(world: Tensor, image_size: tuple[int, int]) -> Tensor:
    """Normalised ``[cx, cy, w, h, d]`` (..., 5) -> pixel xyxy (..., 4)."""
    w, h = image_size
    cx, cy, bw, bh = world[..., 0] * w, world[..., 1] * h, world[..., 2] * w, world[..., 3] * h
    return torch.stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2], dim=-1)


def iou(a: Tensor, b: Tensor) -> Tensor:
    """IoU of pixel xyxy boxes (..., 4), differentiable."""
    ix = (torch.minimum(a[..., 2], b[..., 2]) - torch.maximum(a[..., 0], b[..., 0])).clamp(min=0)
    iy = (torch.minimum(a[..., 3], b[..., 3]) - torch.maximum(a[..., 1], b[..., 1])).clamp(min=0)
    inter = ix * iy
    area_a = (a[..., 2] - a[..., 0]).clamp(min=0) * (a[..., 3] - a[..., 1]).clamp(min=0)
    area_b = (b[..., 2] - b[..., 0]).clamp(min=0) * (b[..., 3] - b[..., 1]).clamp(min=0)
    return inter / (area_a + area_b - inter).clamp(min=1e-6)


def box_loss(world: Tensor, final_boxes: Tensor, mask: Tensor,
             image_size: tuple[int, int]) -> Tensor:
    """Loss per row (R,) of worlds (R, N, 5) against gold final boxes (R, N, 4)."""
    return (_per_object(world_to_boxes(world, image_size), final_boxes) * mask).sum(-1)


def _per_object(pred: Tensor, gold: Tensor) -> Tensor:
    """L1 of the pixel corners in units of 40 px, plus ``1 - IoU``, per box (...)."""
    return (pred - gold).abs().sum(-1) / 40.0 + (1.0 - iou(pred, gold))


def mover_and_base(initial_boxes: Tensor, final_boxes: Tensor, mask: Tensor
                   ) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """From the boxes alone: which objects moved (R, N), and where exactly one did, its
    index, the index of the object whose final box centre is nearest its final box centre
    (the likely base), and whether that holds (R,)."""
    moved = (iou(initial_boxes, final_boxes) <= 0.9) & mask
    single = moved.sum(-1) == 1
    centre = (final_boxes[..., :2] + final_boxes[..., 2:]) / 2
    mover = moved.float().argmax(-1)
    mc = centre[torch.arange(len(centre)), mover]
    dist = (centre - mc[:, None, :]).norm(dim=-1).masked_fill(~mask | moved, 1e9)
    return moved, mover, dist.argmin(-1), single


def simulator_loss(sim: torch.nn.Module, geometry: Tensor, action: Tensor,
                   initial_boxes: Tensor, final_boxes: Tensor, mask: Tensor,
                   image_size: tuple[int, int]) -> Tensor:
    """Per row (R,): where one object moved, the box loss of the action simulator run on
    that object and its likely base (:func:`mover_and_base`) with the parser's action
    ``action`` (R, 3), against the mover's final box. A direct signal for the simulator
    (and, through its action input, for the action words) while the programs are still
    poor; everything in it is read off the initial and final boxes."""
    _, mover, base, single = mover_and_base(initial_boxes, final_boxes, mask)
    r = torch.arange(len(geometry))
    new = sim(geometry[r, mover], geometry[r, base], action)
    return _per_object(world_to_boxes(new, image_size), final_boxes[r, mover]) * single


def identification_loss(subjects: Tensor, bases: Tensor, piece_mask: Tensor,
                        initial_boxes: Tensor, final_boxes: Tensor, mask: Tensor) -> Tensor:
    """Per row (R,): what the final boxes say about who moved and next to whom.

    - Every step's subject should be an object whose final box differs from its initial
      one (IoU <= 0.9): ``-log`` of the subject's mass on those objects.
    - Where exactly one object moved, the base should be the other object whose final box
      centre is nearest the moved object's final box centre: ``-log`` of its mass.

    Both are read off the initial and final boxes alone (no program, no intermediate
    state); they give the visual concepts a direct signal before the action simulator
    has learnt where things go. ``subjects``, ``bases``: (R, P, N).
    """
    moved, _, target, single = mover_and_base(initial_boxes, final_boxes, mask)
    mass = (subjects * moved[:, None, :]).sum(-1).clamp(min=1e-6)
    subj = -(torch.log(mass) * piece_mask).sum(-1) * moved.any(-1)
    bmass = bases[:, 0].gather(1, target[:, None]).squeeze(1).clamp(min=1e-6)
    return subj - torch.log(bmass) * (single & (piece_mask.sum(-1) == 1))


def execution_loss(sim: torch.nn.Module, world: Tensor, subjects: Tensor, bases: Tensor,
                   actions: Tensor, piece_mask: Tensor, geometry: Tensor,
                   initial_boxes: Tensor, final_boxes: Tensor, mask: Tensor,
                   image_size: tuple[int, int]) -> Tensor:
    """The whole loss per row (R,) of an execution: the final world's :func:`box_loss`,
    :func:`identification_loss` of its per-step ``subjects`` and ``bases`` (R, P, N), and,
    for one-step rows (``piece_mask`` (R, P) with P == 1), :func:`simulator_loss` with the
    step's ``actions`` (R, P, 3). NSRM and NMN+ train on it."""
    loss = (box_loss(world, final_boxes, mask, image_size)
            + identification_loss(subjects, bases, piece_mask, initial_boxes, final_boxes,
                                  mask))
    if piece_mask.shape[1] == 1:
        loss = loss + simulator_loss(sim, geometry, actions[:, 0], initial_boxes, final_boxes,
                                     mask, image_size)
    return loss
