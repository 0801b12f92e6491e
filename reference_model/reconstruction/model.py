"""The reconstruction network: a small U-Net that corrects the pasted composite of a step.

Input ``(B, 11, H, W)`` uint8 (:func:`~.inputs.step_inputs`: composite, image before,
plate, old and new box masks), output ``(B, 3, H, W)`` float in [0, 1]: the image after the step.
The output is the composite plus the network's correction inside the union of the masks,
and the image before the step everywhere else. ``H`` and ``W`` must be multiples of 4;
being fully convolutional it trains on patches and runs on whole images.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

__all__ = ["ReconstructionNet"]


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1), nn.ReLU(inplace=True))


class ReconstructionNet(nn.Module):
    """Three-level U-Net (``c``, ``2c``, ``4c`` channels) predicting a residual image."""

    plate: Tensor

    def __init__(self, channels: int = 16, in_channels: int = 11,
                 image_size: tuple[int, int] = (240, 320), head_init_std: float = 0.0
                 ) -> None:
        super().__init__()
        # the empty scene (H, W, 3), set from the training images (part of the checkpoint)
        self.register_buffer("plate", torch.zeros((*image_size, 3), dtype=torch.uint8))
        c = channels
        self.enc1 = _block(in_channels, c)
        self.enc2 = _block(c, 2 * c)
        self.enc3 = _block(2 * c, 4 * c)
        self.up3 = nn.ConvTranspose2d(4 * c, 2 * c, 2, stride=2)
        self.dec2 = _block(4 * c, 2 * c)
        self.up2 = nn.ConvTranspose2d(2 * c, c, 2, stride=2)
        self.dec1 = _block(2 * c, c)
        self.head = nn.Conv2d(c, 3, 1)
        # with std 0 the untrained network outputs the composite itself
        nn.init.normal_(self.head.weight, std=head_init_std)
        assert self.head.bias is not None
        nn.init.zeros_(self.head.bias)

    def forward(self, x: Tensor) -> Tensor:
        """The image after the step, ``(B, 3, H, W)`` in [0, 1]."""
        h, w = x.shape[-2:]
        if h % 4 or w % 4:
            msg = f"ReconstructionNet needs H and W that are multiples of 4, got {h}x{w}"
            raise ValueError(msg)
        xf = x.float() / 255.0
        comp, before = xf[:, 0:3], xf[:, 3:6]
        region = torch.maximum(xf[:, 9:10], xf[:, 10:11])
        e1 = self.enc1(xf)
        e2 = self.enc2(nn.functional.avg_pool2d(e1, 2))
        e3 = self.enc3(nn.functional.avg_pool2d(e2, 2))
        d2 = self.dec2(torch.cat([self.up3(e3), e2], 1))
        d1 = self.dec1(torch.cat([self.up2(d2), e1], 1))
        painted = (comp + self.head(d1)).clamp(0.0, 1.0)
        out: Tensor = before * (1.0 - region) + painted * region
        return out
