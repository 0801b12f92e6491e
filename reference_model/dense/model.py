"""The dense network's parts: a text encoder and a fully convolutional stream, Transporter-style.

* **Text**: word embeddings and a BiGRU; its final states give every conv layer of a
  stream a FiLM scale and shift (the instruction conditions the image features).
* **Stream**: RGB-D plus two coordinate channels, pooled to ``1/scale`` of the image,
  through a small U-shaped FCN (a stride-2 stem, one more stride-2 level with two dilated
  layers for context) to its channels per cell of a grid at ``1/(2 scale)`` of the image:
  40 x 30 cells of 8 px for 320 x 240 and scale 4. The pick heatmap is one such stream;
  the transport (:mod:`.transport`) adds two more for its keys and queries.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.tokens import PAD

__all__ = ["IMAGE_CHANNELS", "FiLMConv", "Stream", "TextEncoder", "coordinates"]

IMAGE_CHANNELS = 4  # RGB and depth


class TextEncoder(nn.Module):
    """Tokens (B, T) -> instruction vector (B, 2 * hidden)."""

    def __init__(self, vocab_size: int, word_dim: int, hidden: int) -> None:
        super().__init__()
        self.embed = nn.Embedding(vocab_size, word_dim, padding_idx=PAD)
        self.gru = nn.GRU(word_dim, hidden, batch_first=True, bidirectional=True)

    def forward(self, tokens: Tensor) -> Tensor:
        lengths = (tokens != PAD).sum(1).clamp(min=1).cpu()
        packed = nn.utils.rnn.pack_padded_sequence(self.embed(tokens), lengths,
                                                   batch_first=True, enforce_sorted=False)
        _, h = self.gru(packed)  # (2, B, hidden)
        return torch.cat([h[0], h[1]], dim=-1)


class FiLMConv(nn.Module):
    """3x3 conv, then ``relu(x * (1 + gamma) + beta)`` with gamma, beta from the text."""

    def __init__(self, c_in: int, c_out: int, text_dim: int, *, stride: int = 1,
                 dilation: int = 1) -> None:
        super().__init__()
        self.conv = nn.Conv2d(c_in, c_out, 3, stride=stride, padding=dilation,
                              dilation=dilation)
        self.film = nn.Linear(text_dim, 2 * c_out)
        nn.init.zeros_(self.film.weight)
        nn.init.zeros_(self.film.bias)

    def forward(self, x: Tensor, text: Tensor) -> Tensor:
        gamma, beta = self.film(text)[:, :, None, None].chunk(2, dim=1)
        return F.relu(self.conv(x) * (1 + gamma) + beta)


class Stream(nn.Module):
    """A U-shaped FCN: (B, c_in, H, W) and text -> logits (B, H/2, W/2).

    A stride-2 stem (H/2), a stride-2 level (H/4) with two dilated layers for context,
    back up to H/2 with the stem's features added, and a 1x1 head (``c_out`` channels:
    :meth:`features` gives them all, ``forward`` the first)."""

    def __init__(self, c_in: int, width: int, text_dim: int, c_out: int = 1) -> None:
        super().__init__()
        w2 = 2 * width
        self.stem = FiLMConv(c_in, width, text_dim, stride=2)
        self.down = FiLMConv(width, w2, text_dim, stride=2)
        self.ctx1 = FiLMConv(w2, w2, text_dim, dilation=2)
        self.ctx2 = FiLMConv(w2, w2, text_dim, dilation=4)
        self.lateral = nn.Conv2d(w2, width, 1)
        self.out = FiLMConv(width, width, text_dim)
        self.head = nn.Conv2d(width, c_out, 1)

    def features(self, x: Tensor, text: Tensor) -> Tensor:
        """(B, c_out, H/2, W/2): the head's output."""
        skip = self.stem(x, text)
        h = self.ctx2(self.ctx1(self.down(skip, text), text), text)
        up = F.interpolate(self.lateral(h), size=skip.shape[-2:], mode="nearest")
        out: Tensor = self.head(self.out(skip + up, text))
        return out

    def forward(self, x: Tensor, text: Tensor) -> Tensor:
        out: Tensor = self.features(x, text)[:, 0]
        return out


def coordinates(batch: int, height: int, width: int) -> Tensor:
    """Two channels (B, 2, H, W): x and y in [-1, 1]."""
    ys = torch.linspace(-1.0, 1.0, height)[:, None].expand(height, width)
    xs = torch.linspace(-1.0, 1.0, width)[None, :].expand(height, width)
    return torch.stack([xs, ys])[None].expand(batch, 2, height, width)
