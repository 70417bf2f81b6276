"""Depth images moved to another camera pose: back-projection, rigid motion, projection with a z-buffer,
and a stated fill of what the move uncovered. numpy and OpenCV only."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from d2sr.frames.base import Intrinsics

__all__ = ["FILL_SHARE", "Pose", "fill_from_background", "fill_radius", "guess_intrinsics", "warp_depth"]

#: How far a hole is filled inward from its farther (background) side, as a share of the image width (32 px
#: at 640). Chosen on the development sequence, the hand-held D435 (docs/fill.md: 16 px left 87% of
#: hold-last's coverage at 6 frames of 30, 32 px 92%); each filled pixel's confidence falls with distance.
FILL_SHARE = 0.05


def fill_radius(width: int) -> int:
    """Pixels of fill for an image ``width`` wide."""
    return max(1, round(FILL_SHARE * width))


@dataclass(frozen=True)
class Pose:
    """A rigid motion taking points from one camera's frame into another's: ``x' = R x + t`` (metres)."""

    R: np.ndarray
    t: np.ndarray

    @staticmethod
    def identity() -> Pose:
        return Pose(np.eye(3), np.zeros(3))

    def then(self, other: Pose) -> Pose:
        """This motion followed by ``other``."""
        return Pose(other.R @ self.R, other.R @ self.t + other.t)

    def inverse(self) -> Pose:
        return Pose(self.R.T, -self.R.T @ self.t)


def guess_intrinsics(width: int, height: int) -> Intrinsics:
    """A pinhole guess for a camera whose intrinsics were not recorded: the principal point at the centre
    and a 55-degree horizontal field of view (fx = 0.95 x width; a D435 colour stream at 640x480 is about
    605-617 px). The warp's error is insensitive to a few percent of focal length (docs/fill.md)."""
    f = 0.95 * width
    return Intrinsics(width, height, f, f, (width - 1) / 2, (height - 1) / 2)


def warp_depth(metres: np.ndarray, pose: Pose, k: Intrinsics) -> np.ndarray:
    """``metres`` (0 = no return) as the camera moved by ``pose`` would see it: the nearest surface wins
    each pixel, single-pixel cracks between projected points are closed, and what the move uncovered is 0."""
    h, w = metres.shape
    v, u = np.nonzero(metres > 0)
    z = metres[v, u].astype(np.float64)
    pts = np.stack([(u - k.px) * z / k.fx, (v - k.py) * z / k.fy, z], axis=1) @ pose.R.T + pose.t
    ahead = pts[:, 2] > 0.05
    pts = pts[ahead]
    uu = np.rint(pts[:, 0] / pts[:, 2] * k.fx + k.px).astype(np.int64)
    vv = np.rint(pts[:, 1] / pts[:, 2] * k.fy + k.py).astype(np.int64)
    inside = (uu >= 0) & (uu < w) & (vv >= 0) & (vv < h)
    out = np.full(h * w, np.inf)
    np.minimum.at(out, vv[inside] * w + uu[inside], pts[inside, 2])
    out = out.reshape(h, w)
    empty = np.isinf(out)
    nearest = cv2.erode(np.where(empty, 1e9, out).astype(np.float32), np.ones((3, 3), np.uint8))
    crack = empty & (nearest < 1e8)
    out[crack] = nearest[crack]
    out[np.isinf(out)] = 0
    return out.astype(np.float32)


def fill_from_background(metres: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Holes grown over from their farther side, one pixel a step for ``radius`` steps (what a move
    uncovers is mostly background). Returns the filled depth and each pixel's confidence: 1 where it was
    warped, falling linearly to 0 at ``radius`` for filled ones, 0 where still empty."""
    out = metres.astype(np.float32).copy()
    conf = (out > 0).astype(np.float32)
    kernel = np.ones((3, 3), np.uint8)
    for step in range(1, radius + 1):
        hole = out == 0
        if not hole.any():
            break
        grown = cv2.dilate(out, kernel)
        new = hole & (grown > 0)
        out[new] = grown[new]
        conf[new] = 1.0 - step / (radius + 1)
    return out, conf
