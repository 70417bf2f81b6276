"""Frame-level interference detectors.

``PaperDetector`` follows the paper's Fig. 4: a few convolutions, each followed by LeakyReLU, and a last
convolution whose asymmetric (118, 1) kernel spans the whole image height at quarter resolution, then a
sigmoid. It needs an input height of 480 (its kernel is tied to it).

``FastDetector`` (our default) sees the same whole frame but reaches it differently: a 4x4 stride-4 stem,
three strided 3x3 convolutions down to 1/32 resolution, then global max and mean pooling. Max pooling lets
a small patch of interference decide the frame (the paper's tall kernel averages along columns instead),
and no layer runs at full resolution, which is where the time goes on a CPU.
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["REF_SHARE", "FastDetector", "MaskDetector", "PaperDetector", "Scored"]

REF_SHARE = 0.005  # a mask detector scores 0.5 where this share of the frame's returns is masked
SHARPNESS = 8.0  # per unit of mask logit: a pixel 1 below the cut counts 0.0003


def features(depth: torch.Tensor) -> torch.Tensor:
    """Depth in metres (N, C, H, W) -> each channel's (scaled depth, return indicator): a zero is
    information, not a short range."""
    parts = [[d * 0.25, (d > 0).to(d.dtype)] for d in depth.split(1, dim=1)]
    return torch.cat([t for p in parts for t in p], dim=1)


class FastDetector(nn.Module):
    """Our detector. ``forward`` returns logits, shape (N,); ``Scored`` (export) adds the sigmoid.

    ``frames=2`` (the temporal detector) also takes the sensor's previous frame as a second channel:
    interference flickers from frame to frame while a sensor's own artefacts stay. With no previous frame
    (a single image, the first frame of a stream) the frame itself is given as its own previous one; the
    model is trained on that case too. In inference (eval mode) a frame is scored twice, with its previous
    frame and alone, and the lower logit counts: it is flagged only when it looks interfered on its own
    and unlike the frame before: the pair alone reads a sensor's own flicker as interference (docs/models.md
    has the figures)."""

    stride = 32

    def __init__(self, width: int = 24, frames: int = 1) -> None:
        super().__init__()
        w = width
        self.frames = frames
        act = nn.LeakyReLU(0.1)
        self.body = nn.Sequential(
            nn.Conv2d(2 * frames, w, 4, stride=4),
            act,
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1),
            act,
            nn.Conv2d(2 * w, 2 * w, 3, stride=2, padding=1),
            act,
            nn.Conv2d(2 * w, 4 * w, 3, stride=2, padding=1),
            act,
        )
        self.head = nn.Linear(8 * w, 1)

    def logit(self, depth: torch.Tensor) -> torch.Tensor:
        f = self.body(features(depth))
        pooled = torch.cat([f.amax(dim=(2, 3)), f.mean(dim=(2, 3))], dim=1)
        out: torch.Tensor = self.head(pooled)[:, 0]
        return out

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        if self.frames == 1 or self.training:
            return self.logit(depth)
        alone = torch.cat([depth[:, :1], depth[:, :1]], dim=1)
        pair, single = self.logit(torch.cat([depth, alone], dim=0)).chunk(2)
        return torch.minimum(pair, single)


class PaperDetector(nn.Module):
    """The paper's detector (Fig. 4): conv + LeakyReLU layers, a (118, 1) convolution over the image height
    at quarter resolution, sigmoid. Needs height 480."""

    stride = 4
    height = 480

    def __init__(self, width: int = 8) -> None:
        super().__init__()
        w = width
        act = nn.LeakyReLU(0.1)
        self.body = nn.Sequential(
            nn.Conv2d(2, w, 3, stride=2, padding=1),
            act,
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1),
            act,
            nn.Conv2d(2 * w, 2 * w, 3),  # 120 rows -> 118
            act,
        )
        self.tall = nn.Conv2d(2 * w, 1, (118, 1))

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        return self.tall(self.body(features(depth))).mean(dim=(1, 2, 3))


class MaskDetector(nn.Module):
    """A recovery model's mask head as a frame detector (what ``d2sr adapt`` writes). A frame's logit is
    ``log(share / REF_SHARE)``, ``share`` being the pixels whose mask logit exceeds ``cut`` (the model's
    repair threshold) over the frame's returns: its probability is ``share / (share + REF_SHARE)``. Not
    trained on its own (the count is not a gradient's path); ``d2sr adapt`` fine-tunes the model inside.

    Why: adapted to a new sensor, a fine-tuned frame CNN scored its clean and corrupted frames in one band,
    where the adapted unet8's mask set them apart (docs/adapt.md has the figures): the mask learns from
    every pixel, the CNN from one label per frame. Costs one recovery pass."""

    def __init__(self, net: nn.Module, cut: float = 0.0) -> None:
        super().__init__()
        self.net = net
        self.frames = int(getattr(net, "frames", 1))
        self.stride = int(getattr(net, "stride", 1))
        self.register_buffer("cut", torch.tensor(float(cut)))

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        logit, _ = self.net(depth[:, : self.frames])
        # A steep sigmoid, not a step: onnxruntime and torch differ by ~1e-6 in a logit, and a step at the cut
        # would let that flip pixels, and the score by up to 1/(pixels x REF_SHARE).
        hits = torch.sigmoid(SHARPNESS * (logit[:, 0] - self.cut)).sum(dim=(1, 2))
        returns = (depth[:, 0] > 0).to(depth.dtype).sum(dim=(1, 2)).clamp(min=1.0)
        share = (hits / returns).clamp(max=1.0)
        return torch.log((share + 1e-6) / REF_SHARE)


class Scored(nn.Module):
    """A detector whose output is the probability that each frame is interfered (what gets exported)."""

    def __init__(self, detector: nn.Module) -> None:
        super().__init__()
        self.detector = detector

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.detector(depth))
