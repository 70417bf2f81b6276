"""The two-head recovery UNet (paper Fig. 6): one trunk, a mask head and a depth head.

``UNet(width, s2d)``: four levels with ``width``, 2x, 4x, 8x filters and two 3x3 convolutions per level.
``s2d=1`` is the paper's layout (the first level at full resolution). Our registered models use ``s2d=4``
(the class default is 2), which folds each 4x4 block of pixels into channels before the trunk and unfolds
the heads' outputs after it (pixel-unshuffle / pixel-shuffle): the full-resolution level is where a plain
UNet spends most of its time, and the heads still decide every pixel because they also see the input's own
pixels.

Depth head. The paper's head regresses depth outright (``fill=False``, kept for the paper-* variants). Ours
(``fill=True``) predicts a correction to a push-pull fill of the pixels the mask head trusts: trained on
generated rooms only, an absolute-depth head was 4-9x worse than OpenCV inpainting inside the true mask on
real L515 frames, while a fill from the surrounding real pixels carries over to any scene.

Temporal variant (``frames=2``): the input's second channel is the sensor's last clean frame (0 where it
has none); a third head output gates between that frame and the fill, per pixel.

``forward`` returns (mask logits, depth in metres); ``repair`` applies the paper's composition with a hard
mask, so pixels outside the predicted mask come out bit-identical.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from d2sr.models.detector import features

__all__ = ["UNet", "push_pull", "pyramid_fill", "space_to_depth"]

FILL_LEVELS = 5  # push-pull pyramid depth: 1/32 resolution, what every model's stride already divides


def push_pull(depth: torch.Tensor, weight: torch.Tensor, levels: int = FILL_LEVELS) -> torch.Tensor:
    """Fill low-weight pixels from the weighted average of their surroundings, coarse to fine (Gortler et
    al.'s push-pull): each level keeps its own estimate in proportion to how much trusted weight it holds
    and takes the rest from the level below. Pixels of weight 1 come out as they went in."""
    return pyramid_fill(depth * weight, weight, levels)


def pyramid_fill(value: torch.Tensor, weight: torch.Tensor, levels: int) -> torch.Tensor:
    """``push_pull``'s pyramid from its finest level: ``value`` (depth x weight) and ``weight``."""
    vs, ws = [value], [weight]
    for _ in range(levels):
        vs.append(F.avg_pool2d(vs[-1], 2))
        ws.append(F.avg_pool2d(ws[-1], 2))
    total = ws[-1].sum(dim=(2, 3), keepdim=True)
    mean = vs[-1].sum(dim=(2, 3), keepdim=True) / total.clamp(min=1e-6)  # for regions with no weight at all
    est = torch.where(ws[-1] > 1e-6, vs[-1] / ws[-1].clamp(min=1e-6), mean)
    for k in range(levels - 1, -1, -1):
        up = F.interpolate(est, scale_factor=2.0, mode="bilinear", align_corners=False)
        est = vs[k] + (1 - ws[k]) * up
    return est


class _SpaceToDepth(torch.autograd.Function):
    """``F.pixel_unshuffle`` exported as ONNX ``SpaceToDepth`` (one copy) and a ``Gather`` of its channels
    into pixel_unshuffle's order: the same values bit for bit, about half the one-hot convolution's time and
    a fraction of the 6-D transpose torch would export."""

    @staticmethod
    def forward(ctx: Any, x: torch.Tensor, s: int, c: int) -> torch.Tensor:
        return F.pixel_unshuffle(x, s)

    @staticmethod
    def symbolic(g: Any, x: Any, s: int, c: int) -> Any:
        k = s * s
        # pixel_unshuffle's channel ch * k + i holds SpaceToDepth's channel i * c + ch.
        order = torch.tensor([i * c + ch for ch in range(c) for i in range(k)], dtype=torch.int64)
        folded = g.op("SpaceToDepth", x, blocksize_i=s)
        return g.op("Gather", folded, g.op("Constant", value_t=order), axis_i=1)


def space_to_depth(x: torch.Tensor, s: int, c: int) -> torch.Tensor:
    """``F.pixel_unshuffle(x, s)`` of ``x`` with ``c`` channels (a constant: a traced shape would make the
    channel order part of the graph); in ONNX export ``SpaceToDepth`` and a ``Gather`` (``_SpaceToDepth``)."""
    if not torch.onnx.is_in_onnx_export():
        return F.pixel_unshuffle(x, s)
    return _SpaceToDepth.apply(x, s, c)


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, padding=1),
        nn.ReLU(inplace=True),
        nn.Conv2d(cout, cout, 3, padding=1),
        nn.ReLU(inplace=True),
    )


class UNet(nn.Module):
    levels = 4

    def __init__(
        self, width: int = 8, s2d: int = 2, hidden: int = 0, fill: bool = False, frames: int = 1
    ) -> None:
        super().__init__()
        if frames > 1 and not fill:
            raise ValueError("the temporal variant gates between the last clean frame and the fill")
        self.width, self.s2d, self.fill, self.frames = width, s2d, fill, frames
        self.stride = max(s2d * 2 ** (self.levels - 1), 2**FILL_LEVELS if fill else 1)
        cin = 2 * frames * s2d * s2d
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
            nn.Conv2d(widths[0] + cin, hidden, 1),
            nn.ReLU(inplace=True),
            nn.Conv2d(hidden, (2 + (frames > 1)) * s2d * s2d, 1),
        )

    def forward(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        # Per frame (depth, return indicator), current frame first: the layout of a one-frame model plus more.
        x = torch.cat([features(depth[:, k : k + 1]) for k in range(self.frames)], dim=1)
        if self.s2d > 1:
            x = space_to_depth(x, self.s2d, 2 * self.frames)
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
        mask_logit, depth_out = out[:, :1], out[:, 1:2] * 4.0
        if not self.fill:
            return mask_logit, depth_out
        cur = depth[:, :1]
        # The fill's sources: returns the mask head does not flag (detached: the mask learns from its own
        # losses, not from making the fill easier).
        trust = (cur > 0).to(cur.dtype) * (1 - torch.sigmoid(mask_logit.detach()))
        base = push_pull(cur, trust)
        if self.frames > 1:
            prev = depth[:, 1:2]
            gate = torch.sigmoid(out[:, 2:3]) * (prev > 0).to(prev.dtype)
            base = gate * prev + (1 - gate) * base
        return mask_logit, base + depth_out

    def repair(self, depth: torch.Tensor, mask_logit: float = 0.0) -> tuple[torch.Tensor, torch.Tensor]:
        """(repaired depth, hard mask): predicted depth where the mask logit exceeds ``mask_logit``, the
        input elsewhere."""
        logit, pred = self(depth)
        mask = logit > mask_logit
        return torch.where(mask, pred.clamp(min=0), depth[:, :1]), mask
