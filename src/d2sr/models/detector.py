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

__all__ = ["FastDetector", "PaperDetector", "Scored"]


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
    and unlike the frame before. On real clean L515 frames the pair alone flagged 8% (the sensor's own
    flicker), the frame alone 2-5%, both together 2-5%; see docs/models.md."""

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


class Scored(nn.Module):
    """A detector whose output is the probability that each frame is interfered (what gets exported)."""

    def __init__(self, detector: nn.Module) -> None:
        super().__init__()
        self.detector = detector

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.detector(depth))
