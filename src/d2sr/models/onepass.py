"""A recovery model built for one pass at the camera's rate (``unet8-fast``).

The same two heads as ``d2sr.models.unet.UNet`` (mask logits; depth as a fill of the trusted returns plus
a correction), laid out so that almost nothing runs at full resolution:

- each 8x8 block of pixels is folded into channels (ONNX ``SpaceToDepth``, one cheap kernel) and a 1x1 stem
  mixes them down to ``width`` channels, so the trunk (three levels) runs at 1/8, 1/16 and 1/32;
- the heads (``RowHead``) see the trunk's context and, per row of a block, the row's own pixels, and unfold
  back (``DepthToSpace``): every pixel still decides for itself, with units that see it and its row (a
  few units shared by a whole block cannot decide per pixel; lab/notes/decisions.md);
- the fill trusts a return where the mask logit is below 0 (a hard cut: it only feeds the fill, whose
  gradient is detached anyway) and pushes and pulls from the 1/8 grid, one upsampling to full resolution.

It is distilled from the two-pass ``unet8`` (``TrainSettings.teacher``), so one pass does what two do.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from d2sr.contract.catalog import CATALOG, FAST_RECOVERY
from d2sr.models.detector import features
from d2sr.models.unet import FILL_LEVELS, _block, pyramid_fill

__all__ = ["OnePassUNet", "RowHead", "block_fill", "fold"]


def _fold(x: torch.Tensor, s: int) -> torch.Tensor:
    n, c, h, w = x.shape
    y = x.reshape(n, c, h // s, s, w // s, s).permute(0, 3, 5, 1, 2, 4)
    return y.reshape(n, s * s * c, h // s, w // s)


class _Fold(torch.autograd.Function):
    """``_fold`` exported as one ONNX ``SpaceToDepth`` node (the same order), which onnxruntime runs in a
    fraction of the 6-D transpose torch would export."""

    @staticmethod
    def forward(ctx: Any, x: torch.Tensor, s: int) -> torch.Tensor:
        return _fold(x, s)

    @staticmethod
    def symbolic(g: Any, x: Any, s: int) -> Any:
        return g.op("SpaceToDepth", x, blocksize_i=s)


def fold(x: torch.Tensor, s: int) -> torch.Tensor:
    """(N, C, H, W) -> (N, s*s*C, H/s, W/s), channel (i*s + j)*C + c holding channel c at (i, j) of a block
    (ONNX's order, not ``pixel_unshuffle``'s)."""
    if torch.onnx.is_in_onnx_export():
        return _Fold.apply(x, s)
    return _fold(x, s)


def _bilinear(s: int) -> torch.Tensor:
    """(s*s, 1, 3, 3): for each pixel (i, j) of a block, the weights of the 3x3 blocks around it that a
    bilinear upsampling by ``s`` gives it (align_corners=False): an upsampling as a convolution on the
    block grid, its output already folded."""
    u = (torch.arange(s, dtype=torch.float32) + 0.5) / s - 0.5  # offset from the block's centre, in blocks
    w = torch.stack([(-u).clamp(min=0), 1 - u.abs(), u.clamp(min=0)], dim=1)  # (s, 3): left, centre, right
    return (w[:, None, :, None] * w[None, :, None, :]).reshape(s * s, 1, 3, 3)


def block_fill(depth: torch.Tensor, trust: torch.Tensor, s: int, levels: int) -> torch.Tensor:
    """Push-pull fill (``d2sr.models.unet.push_pull``) on the grid of ``s`` x ``s`` blocks, folded: ``depth``
    and ``trust`` are (N, s*s, h, w) as ``fold`` lays out one channel; returns each pixel's fill in the same
    layout, the block grid's estimate bilinearly upsampled (every pixel's, trusted or not: only masked ones
    are used)."""
    est = pyramid_fill((depth * trust).mean(dim=1, keepdim=True), trust.mean(dim=1, keepdim=True), levels)
    return F.conv2d(F.pad(est, (1, 1, 1, 1), mode="replicate"), _bilinear(s).to(est.dtype))


class RowHead(nn.Module):
    """The heads, per row of a block: the row's ``s`` pixels (their depth and return indicator, as ``fold``
    lays out two channels) and the block's context from the trunk -> each pixel's mask logit and depth
    correction, in the same order. ``hidden`` units a row: every pixel decides with units that see it and
    its row, not with a few shared by the whole block."""

    def __init__(self, context: int, s: int, hidden: int) -> None:
        super().__init__()
        self.context = nn.Conv2d(context, s * hidden, 1)
        self.own = nn.Conv2d(2 * s * s, s * hidden, 1, groups=s)
        self.out = nn.Conv2d(s * hidden, 2 * s * s, 1, groups=s)

    def forward(self, h: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        return self.out(F.relu(self.context(h) + self.own(x)))


class OnePassUNet(nn.Module):
    """Mask logits and depth (metres) of one frame, (N, 1, H, W) each; H and W divisible by ``stride``."""

    levels = 3
    s2d = 8
    fill = True
    frames = 1
    passes = CATALOG[FAST_RECOVERY].passes

    def __init__(self, width: int = 8, hidden: int = 32) -> None:
        super().__init__()
        self.width = width
        self.stride = self.s2d * 2 ** (self.levels - 1)
        widths = [width * 2**i for i in range(self.levels)]
        self.stem = nn.Sequential(nn.Conv2d(2 * self.s2d * self.s2d, width, 1), nn.ReLU(inplace=True))
        self.down = nn.ModuleList(_block(c, w) for c, w in zip([width, *widths[:-1]], widths, strict=True))
        self.up = nn.ModuleList(_block(widths[i + 1] + widths[i], widths[i]) for i in range(self.levels - 1))
        self.head = RowHead(widths[0], self.s2d, hidden)

    def forward(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        # Channel (i * s2d + j) * 2 + c: feature c (depth / 4, return) of pixel (i, j) of each block; a block
        # row's pixels are consecutive channels, what the heads' groups take.
        x = fold(features(depth), self.s2d)
        d = x[:, 0::2] * 4.0  # depth, channel i * s2d + j: pixel_shuffle's order for one channel
        h = self.stem(x)
        skips = []
        for i, block in enumerate(self.down):
            h = block(F.max_pool2d(h, 2) if i else h)
            skips.append(h)
        for i in range(self.levels - 2, -1, -1):
            h = self.up[i](torch.cat([F.interpolate(h, scale_factor=2.0, mode="nearest"), skips[i]], dim=1))
        out = self.head(h, x)
        logit, correction = out[:, 0::2], out[:, 1::2]
        trust = ((d > 0) & (logit.detach() < 0)).to(d.dtype)
        pred = block_fill(d, trust, self.s2d, FILL_LEVELS - (self.s2d.bit_length() - 1)) + 4.0 * correction
        return F.pixel_shuffle(logit, self.s2d), F.pixel_shuffle(pred, self.s2d)
