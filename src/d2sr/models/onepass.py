"""A recovery model built for one pass at the camera's rate (``unet8-fast``).

unet8's trunk (``d2sr.models.unet.UNet``: four levels, width 8) runs on the grid of 8x8 blocks, a quarter
of its work at 640x480; the heads still decide every pixel:

- the frame's 8x8 blocks are folded into channels once (ONNX ``SpaceToDepth``) and a 1x1 stem gives the
  trunk every pixel of a block as the 32 channels unet8's first convolution takes; it starts as the
  selection of each block's (even row, even column) pixels, unet8's 4x4 cells at half resolution, so the
  model starts as unet8 run at half resolution (the same parameter names);
- the heads run per 2x2 phase of a block (grouped 1x1 convolutions): each pixel's mask logit and depth
  correction come from its own phase's 16 pixels and the block's context, unet8's head at half
  resolution laid four times side by side, narrower;
- the fill is unet8's push-pull on the half-resolution frame, trusted where that frame's own logits say so,
  repeated to each 2x2 block; each pixel's correction then moves its own depth.

Distilled from unet8's two passes (``TrainSettings.teacher``), so one pass does what two do.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from d2sr.contract.catalog import CATALOG, FAST_RECOVERY
from d2sr.errors import InputError
from d2sr.models.unet import UNet, _block, push_pull, space_to_depth

__all__ = ["OnePassUNet", "grid_pad", "phase_channels", "repeat2"]

_B = 8  # pixels a block side: 2 (phases) x 4 (unet8's cell at half resolution)
_HIDDEN = 64  # units a phase: unet8's head's, so each phase starts as that head


def phase_channels(a: int, b: int) -> list[int]:
    """The 16 channels of a folded frame (channel ``i * 8 + j``: pixel (i, j) of a block) that hold phase
    (a, b), in the order unet8's fold of the half-resolution frame lays out its 4x4 cell: ``k * 4 + m`` for
    the phase's pixel (2k + a, 2m + b)."""
    return [(2 * k + a) * _B + 2 * m + b for k in range(4) for m in range(4)]


_PHASES = [(a, b) for a in range(2) for b in range(2)]
_OWN = [ch for a, b in _PHASES for ch in phase_channels(a, b)]


def _unfold_order(part: int) -> list[int]:
    """For output ``part`` (0: mask logit, 1: correction), the head channels in ``pixel_shuffle``'s order
    for one channel: pixel (i, j) of a block <- phase (i % 2, j % 2)'s channel ``part * 16 + k * 4 + m``."""
    return [
        (2 * (i % 2) + j % 2) * 32 + part * 16 + (i // 2) * 4 + j // 2 for i in range(_B) for j in range(_B)
    ]


_LOGIT, _CORRECTION = _unfold_order(0), _unfold_order(1)


def grid_pad(x: torch.Tensor, multiple: int) -> torch.Tensor:
    """``x`` with a zero border at the bottom and right up to a multiple of ``multiple``; traced from the
    input's shape, so one exported file takes every size."""
    h, w = x.shape[-2], x.shape[-1]
    return F.pad(x, (0, (multiple - w % multiple) % multiple, 0, (multiple - h % multiple) % multiple))


def repeat2(x: torch.Tensor) -> torch.Tensor:
    """Each pixel repeated into a 2x2 block (ONNX ``Resize``, nearest)."""
    return F.interpolate(x, scale_factor=2.0, mode="nearest")


class OnePassUNet(nn.Module):
    """Mask logits and depth (metres) of one frame, (N, 1, H, W) each; H and W divisible by ``stride``."""

    levels = 4
    width = 8
    s2d = _B
    fill = True
    frames = 1
    stride = 32  # the catalogue's padding; the trunk's own grid is padded inside
    passes = CATALOG[FAST_RECOVERY].passes
    phases_order: torch.Tensor
    logit_order: torch.Tensor
    correction_order: torch.Tensor

    def __init__(self) -> None:
        super().__init__()
        hidden = _HIDDEN
        widths = [self.width * 2**k for k in range(self.levels)]
        self.down = nn.ModuleList()
        # The stem: (depth / 4, return) of every pixel of a block -> the 32 channels unet8's first convolution
        # takes (a 1x1 convolution: the first 3x3 one over all 128 cost four times the time). It starts as
        # the selection of phase (0, 0)'s, unet8's input at half resolution (``start_from``).
        self.stem = nn.Sequential(nn.Conv2d(2 * 64, 2 * 16, 1), nn.ReLU(inplace=True))
        c = 2 * 16
        for w in widths:
            self.down.append(_block(c, w))
            c = w
        self.up = nn.ModuleList(_block(widths[k + 1] + widths[k], widths[k]) for k in range(self.levels - 1))
        n = len(_PHASES)
        # Per phase: the block's context, the phase's 16 depths (metres) and whether each returns (unet8's
        # head input at half resolution; the depth's 1/4 is in the weights) -> its units
        # -> its 16 pixels' mask logits and corrections. One grouped convolution each, the context given to
        # every group (a separate context convolution and sum cost more than the copies).
        self.hidden = nn.Conv2d(n * (widths[0] + 32), n * hidden, 1, groups=n)
        self.out = nn.Conv2d(n * hidden, n * 32, 1, groups=n)
        for name, order in (("phases", _OWN), ("logit", _LOGIT), ("correction", _CORRECTION)):
            self.register_buffer(f"{name}_order", torch.tensor(order), persistent=False)

    def _trunk(self, x: torch.Tensor) -> torch.Tensor:
        h, w = x.shape[-2], x.shape[-1]
        y = grid_pad(x, 2 ** (self.levels - 1))
        skips = []
        for k, block in enumerate(self.down):
            y = block(F.max_pool2d(y, 2) if k else y)
            skips.append(y)
        for k in range(self.levels - 2, -1, -1):
            y = self.up[k](torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), skips[k]], dim=1))
        return y[..., :h, :w]

    def forward(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h, w = depth.shape[-2], depth.shape[-1]
        x = space_to_depth(depth[:, :1], _B, 1)  # (N, 64, H / 8, W / 8)
        own = x.index_select(1, self.phases_order)  # phase by phase; phase (0, 0) first
        first, rest = own[:, :16], own[:, 16:]
        returns = (own > 0).to(own.dtype)
        features = torch.cat([first * 0.25, returns[:, :16], rest * 0.25, returns[:, 16:]], dim=1)
        ctx = self._trunk(self.stem(features))
        cut = [slice(16 * k, 16 * (k + 1)) for k in range(len(_PHASES))]
        groups = [t for c in cut for t in (ctx, own[:, c], returns[:, c])]
        out = self.out(F.relu(self.hidden(torch.cat(groups, dim=1))))
        logit = F.pixel_shuffle(out.index_select(1, self.logit_order), _B)
        correction = F.pixel_shuffle(out.index_select(1, self.correction_order), _B)
        # The fill: push-pull on the half-resolution frame (phase (0, 0)), trusted where its logits say,
        # padded on the block grid (cheaper there) to what the pyramid halves.
        pad = 32 // (_B // 2)
        half = F.pixel_shuffle(grid_pad(first, pad), 4)
        sure = torch.sigmoid(F.pixel_shuffle(grid_pad(out[:, :16], pad), 4).detach())
        base = push_pull(half, (half > 0).to(half.dtype) * (1 - sure))[..., : h // 2, : w // 2]
        return logit, repeat2(base) + 4.0 * correction

    @torch.no_grad()
    def start_from(self, unet: UNet) -> None:
        """Become ``unet`` (unet8's layout) at half resolution, each phase with unet8's head: its trunk
        copied, the stem the selection of phase (0, 0), and each phase's units unet8's head units (the
        depth's 1/4 moved into the weights). On phase (0, 0) it is then unet8 run on every second pixel of
        every second row."""
        layout = (unet.width, unet.s2d, unet.fill, unet.frames, unet.levels)
        if layout != (self.width, 4, True, 1, self.levels):
            raise InputError("only unet8's layout (width 8, 4x4 cells, the fill, one frame) starts it")
        first, last = _conv(unet.head[0]), _conv(unet.head[2])
        if first.out_channels * len(_PHASES) != self.hidden.out_channels:
            raise InputError(f"unet8's head has {first.out_channels} units, this {self.hidden.out_channels}")
        own = {k: v for k, v in unet.state_dict().items() if k.startswith(("down.", "up."))}
        self.load_state_dict(own, strict=False)
        stem = _conv(self.stem[0])
        stem.weight.zero_()
        stem.weight[:, :32, 0, 0] = torch.eye(32)  # the features are >= 0: the ReLU passes them as they are
        if stem.bias is not None:
            stem.bias.zero_()
        ctx = self.width
        w = first.weight[:, :, 0, 0]  # (units, context 8 + depth / 4 16 + return 16)
        unit = torch.cat([w[:, :ctx], 0.25 * w[:, ctx : ctx + 16], w[:, ctx + 16 :]], dim=1)
        n = len(_PHASES)
        self.hidden.weight.copy_(unit.repeat(n, 1)[:, :, None, None])
        self.out.weight.copy_(last.weight.repeat(n, 1, 1, 1))
        for mine, theirs in ((self.hidden, first), (self.out, last)):
            if mine.bias is None or theirs.bias is None:
                raise InputError("unet8's head and this one both have biases")
            mine.bias.copy_(theirs.bias.repeat(n))


def _conv(m: nn.Module) -> nn.Conv2d:
    if not isinstance(m, nn.Conv2d):
        raise InputError(f"expected a convolution in unet8's head, found {type(m).__name__}")
    return m
