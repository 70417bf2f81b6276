"""The two-head recovery UNet (paper Fig. 6): one trunk, a mask head and a depth head.

``UNet(width, s2d)``: four levels with ``width``, 2x, 4x, 8x filters and two 3x3 convolutions per level.
``s2d=1`` is the paper's layout (the first level at full resolution). Our default, ``s2d=2``, folds each 2x2
block of pixels into channels before the trunk and unfolds the heads' outputs after it
(pixel-unshuffle / pixel-shuffle): the full-resolution level is where a plain UNet spends most of its time,
and the heads still decide every pixel because they also see the input's own pixels.

``forward`` returns (mask logits, depth in metres); ``repair`` applies the paper's composition with a hard
mask, so pixels outside the predicted mask come out bit-identical.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from d2sr.models.detector import features

__all__ = ["UNet"]


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, padding=1),
        nn.ReLU(inplace=True),
        nn.Conv2d(cout, cout, 3, padding=1),
        nn.ReLU(inplace=True),
    )


class UNet(nn.Module):
    levels = 4

    def __init__(self, width: int = 8, s2d: int = 2, hidden: int = 0) -> None:
        super().__init__()
        self.width, self.s2d = width, s2d
        self.stride = s2d * 2 ** (self.levels - 1)
        cin = 2 * s2d * s2d
        widths = [width * 2**k for k in range(self.levels)]
        self.down = nn.ModuleList()
        c = cin
        for w in widths:
            self.down.append(_block(c, w))
            c = w
        self.up = nn.ModuleList(_block(widths[k + 1] + widths[k], widths[k]) for k in range(self.levels - 1))
        # Heads see the trunk and the input's own pixels: per-pixel decisions survive the space-to-depth.
        # A 1x1 MLP, not a linear map: "is my own depth off the context's" is not linear in the inputs.
        hidden = hidden or max(4 * s2d * s2d, 16)
        self.head = nn.Sequential(
            nn.Conv2d(widths[0] + cin, hidden, 1), nn.ReLU(inplace=True), nn.Conv2d(hidden, 2 * s2d * s2d, 1)
        )

    def forward(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = features(depth)
        if self.s2d > 1:
            x = F.pixel_unshuffle(x, self.s2d)
        skips = []
        h = x
        for k, block in enumerate(self.down):
            if k:
                h = F.max_pool2d(h, 2)
            h = block(h)
            skips.append(h)
        for k in range(self.levels - 2, -1, -1):
            h = F.interpolate(h, scale_factor=2.0, mode="nearest")
            h = self.up[k](torch.cat([h, skips[k]], dim=1))
        out = self.head(torch.cat([h, x], dim=1))
        s = self.s2d
        if s > 1:
            out = F.pixel_shuffle(out, s)
        mask_logit, depth_out = out[:, :1], out[:, 1:] * 4.0
        return mask_logit, depth_out

    def repair(self, depth: torch.Tensor, threshold: float = 0.5) -> tuple[torch.Tensor, torch.Tensor]:
        """(repaired depth, hard mask): predicted depth inside the mask, the input outside it."""
        logit, pred = self(depth)
        mask = logit > torch.logit(torch.tensor(threshold))
        return torch.where(mask, pred.clamp(min=0), depth), mask
