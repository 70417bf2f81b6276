"""The forms two-frame models are exported in for streams (``d2sr.models.onnx.export``), each as two files.
The same functions as the full models, within float rounding (the sums are taken in another order).

- Temporal detector: a frame is scored alone and with its previous frame, and the lower score counts
  (``FastDetector.forward``). The first file scores the frame alone, the second (``contract.pair_path``)
  with its previous frame. A frame that scores below the threshold alone is below it with its previous
  frame too, so the runtime scores the pair only for the frames that reach it (``contract.gate``): a clean
  frame costs one pass of half the work of both.
- Temporal UNet: the part of the first convolution that reads the last clean frame is linear in it, and it
  stays the same for every frame (and both passes) until the next clean frame: it is computed once
  (``code``, and ``head_code`` for the head's first layer) by the encoder, a file of its own
  (``contract.code_path``; onnxruntime computes every output of a graph whether asked for or not), and fed
  in with the frames that follow. Two inputs rather than one to slice: onnxruntime copies a slice.
"""

from __future__ import annotations

from typing import cast

import torch
import torch.nn.functional as F
from torch import nn

from d2sr.contract.catalog import code_path, pair_path
from d2sr.models.detector import FastDetector, features
from d2sr.models.unet import UNet, push_pull, space_to_depth

__all__ = ["Encoder", "Pair", "StreamingDetector", "StreamingUNet", "streaming"]


class StreamingDetector(nn.Module):
    """depth -> probability that the frame alone is interfered, as ``FastDetector`` scores it with itself as
    its previous frame: one stem convolution, both halves' weights summed (``features``' depth scale folded
    in). ``Pair`` scores it with its previous frame."""

    second_path = staticmethod(pair_path)  # where the export puts the Pair beside it

    def __init__(self, det: FastDetector) -> None:
        super().__init__()
        if det.frames != 2:
            raise ValueError("only a two-frame detector has a streaming form")
        self.det = det
        stem = cast(nn.Conv2d, det.body[0])
        scale = features(torch.ones(1, 1, 1, 1))[0, :, 0, 0]  # features() = (scale x depth, return indicator)
        w = stem.weight.detach() * scale.repeat(2)[None, :, None, None]
        k = int(stem.kernel_size[0])
        self.alone = nn.Conv2d(2, stem.out_channels, k, stride=k).requires_grad_(False)
        self.alone.weight.copy_(w[:, :2] + w[:, 2:])
        cast(torch.Tensor, self.alone.bias).copy_(cast(torch.Tensor, stem.bias).detach())
        self.rest = cast(nn.Sequential, det.body[1:])

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        f = self.rest(self.alone(torch.cat([depth, (depth > 0).to(depth.dtype)], dim=1)))
        pooled = torch.cat([f.amax(dim=(2, 3)), f.mean(dim=(2, 3))], dim=1)
        return torch.sigmoid(self.det.head(pooled)[:, 0])


class Pair(nn.Module):
    """(depth, previous frame) -> probability that the frame is interfered, weighed with its previous frame
    (``FastDetector.logit`` on the pair)."""

    def __init__(self, det: FastDetector) -> None:
        super().__init__()
        self.det = det

    def forward(self, depth: torch.Tensor, previous: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.det.logit(torch.cat([depth, previous], dim=1)))


class StreamingUNet(nn.Module):
    """(depth, last clean frame, its code, its head code) -> (mask logits, depth in metres)."""

    second_path = staticmethod(code_path)  # where the export puts its Encoder beside it

    def __init__(self, net: UNet) -> None:
        super().__init__()
        if net.frames != 2:
            raise ValueError("only a two-frame UNet has a streaming form")
        self.net = net
        self.n = 2 * net.s2d * net.s2d  # one frame's channels after space-to-depth
        block = cast(nn.Sequential, net.down[0])
        self.first, self.after = cast(nn.Conv2d, block[0]), cast(nn.Sequential, block[1:])
        self.hidden = cast(nn.Conv2d, net.head[0])
        self.code_stride = net.s2d

    def _s2d(self, depth: torch.Tensor) -> torch.Tensor:
        x = features(depth)
        return space_to_depth(x, self.net.s2d, 2) if self.net.s2d > 1 else x

    def encode(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """A frame's share of the first convolution and of the head's first layer, as the last clean one."""
        x, n, first, hidden = self._s2d(depth), self.n, self.first, self.hidden
        return F.conv2d(x, first.weight[:, n:], padding=1), F.conv2d(x, hidden.weight[:, -n:])

    def forward(
        self, depth: torch.Tensor, previous: torch.Tensor, code: torch.Tensor, head_code: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        net, n = self.net, self.n
        x = self._s2d(depth)
        first, hidden = self.first, self.hidden
        h = self.after(F.conv2d(x, first.weight[:, :n], first.bias, padding=1) + code)
        skips = [h]
        for k in range(1, net.levels):
            h = net.down[k](F.max_pool2d(h, 2))
            skips.append(h)
        for k in range(net.levels - 2, -1, -1):
            h = F.interpolate(h, scale_factor=2.0, mode="nearest")
            h = net.up[k](torch.cat([h, skips[k]], dim=1))
        w = hidden.weight
        mid = F.conv2d(torch.cat([h, x], 1), w[:, : int(w.shape[1]) - n], hidden.bias) + head_code
        out = net.head[2](net.head[1](mid))
        if net.s2d > 1:
            out = F.pixel_shuffle(out, net.s2d)
        logit, delta = out[:, :1], out[:, 1:2] * 4.0
        trust = (depth > 0).to(depth.dtype) * (1 - torch.sigmoid(logit))
        gate = torch.sigmoid(out[:, 2:3]) * (previous > 0).to(previous.dtype)
        base = gate * previous + (1 - gate) * push_pull(depth, trust)
        return logit, base + delta


class Encoder(nn.Module):
    """``StreamingUNet.encode`` as a module of its own, for export."""

    def __init__(self, net: StreamingUNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, previous: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.net.encode(previous)


def streaming(model: nn.Module) -> StreamingDetector | StreamingUNet | None:
    """The streaming form of a two-frame model; None for any other."""
    if isinstance(model, FastDetector) and model.frames == 2:
        return StreamingDetector(model).eval()
    if isinstance(model, UNet) and model.frames == 2:
        return StreamingUNet(model).eval()
    return None
