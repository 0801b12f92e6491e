"""``dense-v2``'s network: a pick stream and a Transporter transport for the place.

* **Text** and **pick stream** (:mod:`.model`; as ``dense-v1`` had them): a BiGRU's final
  states FiLM-condition every conv layer; the pick heatmap is one logit per cell of the
  grid at ``1/(2 scale)`` of the image.
* **Key stream**: an FCN of the pick stream's shape over the whole stream input, ending in
  ``key_dim`` channels per heatmap cell (the scene's key features), FiLM-conditioned on
  the instruction.
* **Query stream**: a second such FCN over a crop of the stream input centred on the pick
  cell (``crop`` heatmap cells a side, ``2 crop`` pooled pixels), rotated about its centre
  over ``rotations`` angles (``grid_sample``; no torchvision), ending in ``key_dim``
  channels per cell: a ``crop x crop`` kernel per angle, FiLM-conditioned on the
  instruction as well.
* **Transport**: the place logit of a cell is the cross-correlation of the key features
  around it with the query kernel (a grouped conv, one group per episode), divided by the
  kernel's side; with several angles the cell's logit is the log-sum-exp over them (the
  angle is not supervised: only the place is).
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.dense.config import DenseV2Config
from nsrmp_bench.reference_model.dense.model import (
    IMAGE_CHANNELS,
    Stream,
    TextEncoder,
    coordinates,
)

__all__ = ["TransportNet", "crop_around", "rotate"]


def crop_around(x: Tensor, cells: Tensor, crop: int) -> Tensor:
    """(B, C, 2 crop, 2 crop): the window of ``x`` (B, C, H, W; H, W = twice the heatmap
    grid) covering the ``crop x crop`` heatmap cells centred on each row's cell (flat
    index on the grid), zero outside the image."""
    b, w = x.shape[0], x.shape[-1]
    grid_w = w // 2
    pad = 2 * (crop // 2)
    xp = F.pad(x, (pad, pad, pad, pad))
    cy, cx = cells // grid_w, cells % grid_w
    span = torch.arange(2 * crop)
    rows = (2 * cy)[:, None] + span[None]  # (B, 2 crop) in padded coordinates
    cols = (2 * cx)[:, None] + span[None]
    batch = torch.arange(b)[:, None, None]
    window = xp.permute(0, 2, 3, 1)[batch, rows[:, :, None], cols[:, None, :]]
    return window.permute(0, 3, 1, 2).contiguous()


def rotate(x: Tensor, k: int) -> Tensor:
    """(B * k, C, S, S): each square window of ``x`` (B, C, S, S) rotated about its centre
    by ``2 pi i / k``, i = 0..k-1 (bilinear, zeros outside); ``k = 1`` returns ``x``."""
    if k == 1:
        return x
    b = x.shape[0]
    angles = torch.arange(k, dtype=x.dtype) * (2 * math.pi / k)
    cos, sin = torch.cos(angles), torch.sin(angles)
    zero = torch.zeros_like(cos)
    theta = torch.stack([torch.stack([cos, -sin, zero], 1),
                         torch.stack([sin, cos, zero], 1)], 1)  # (k, 2, 3)
    theta = theta.repeat(b, 1, 1)
    src = x.repeat_interleave(k, dim=0)
    grid = F.affine_grid(theta, list(src.shape), align_corners=False)
    return F.grid_sample(src, grid, align_corners=False)


class TransportNet(nn.Module):
    """Instruction and RGB-D -> pick logits (attention) and place logits (transport): what
    inference and the loss use of the dense network."""

    def __init__(self, vocab_size: int, cfg: DenseV2Config) -> None:
        super().__init__()
        self.cfg = cfg
        text_dim = 2 * cfg.text_hidden
        c_in = IMAGE_CHANNELS + 2
        self.text = TextEncoder(vocab_size, cfg.word_dim, cfg.text_hidden)
        self.pick = Stream(c_in, cfg.width, text_dim)
        self.key = Stream(c_in, cfg.width, text_dim, c_out=cfg.key_dim)
        self.query = Stream(c_in, cfg.width, text_dim, c_out=cfg.key_dim)

    def image_input(self, image: Tensor) -> Tensor:
        """The stream input: the image (B, 4, H, W) with coordinate channels."""
        b, _, h, w = image.shape
        return torch.cat([image, coordinates(b, h, w)], dim=1)

    def pick_logits(self, x: Tensor, text: Tensor) -> Tensor:
        """(B, H/2 * W/2) pick logits from :meth:`image_input` and the text vector."""
        logits: Tensor = self.pick(x, text)
        return logits.flatten(1)

    def place_logits(self, x: Tensor, text: Tensor, pick_cells: Tensor) -> Tensor:
        """(B, H/2 * W/2) place logits: the key features correlated with the features of
        the crop around each row's pick cell (over the rotations)."""
        b = x.shape[0]
        k, crop = self.cfg.rotations, self.cfg.crop
        keys = self.key.features(x, text)  # (B, D, h, w)
        d, h, w = keys.shape[1:]
        window = rotate(crop_around(x, pick_cells, crop), k)  # (B k, C, 2 crop, 2 crop)
        kernel = self.query.features(window, text.repeat_interleave(k, dim=0))
        # one group per episode: its D key channels against its k kernels
        out = F.conv2d(keys.reshape(1, b * d, h, w), kernel, padding=crop // 2, groups=b)
        logits = out.reshape(b, k, h * w) / crop
        if k > 1:
            return torch.logsumexp(logits, dim=1)
        return logits[:, 0]
