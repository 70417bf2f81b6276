"""Depth images moved to another camera pose: back-projection, rigid motion, projection with a z-buffer,
and a stated fill of what the move uncovered. numpy and OpenCV only."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from d2sr.frames.base import Intrinsics

__all__ = [
    "FILL_SHARE",
    "Cloud",
    "Pose",
    "cloud",
    "fill_from_background",
    "fill_radius",
    "guess_intrinsics",
    "warp_depth",
]

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


@dataclass(frozen=True)
class Cloud:
    """A depth frame's returns as camera-frame points (metres, float32) and the frame's shape: what every
    warp of the same frame starts from (``cloud``), computed once per real frame."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    shape: tuple[int, int]


def cloud(metres: np.ndarray, k: Intrinsics) -> Cloud:
    """``metres``' returns (0 = none) back-projected through ``k``."""
    h, w = metres.shape
    v, u = np.nonzero(metres > 0)
    z = metres[v, u].astype(np.float32)
    x = (u.astype(np.float32) - np.float32(k.px)) * z / np.float32(k.fx)
    y = (v.astype(np.float32) - np.float32(k.py)) * z / np.float32(k.fy)
    return Cloud(x, y, z, (h, w))


def warp_depth(metres: np.ndarray | Cloud, pose: Pose, k: Intrinsics) -> np.ndarray:
    """``metres`` (0 = no return; or its ``cloud``) as the camera moved by ``pose`` would see it: the nearest
    surface wins each pixel, single-pixel cracks between projected points are closed, and what the move
    uncovered is 0."""
    c = metres if isinstance(metres, Cloud) else cloud(metres, k)
    h, w = c.shape
    x, y, z = c.x, c.y, c.z
    rot, t = pose.R.astype(np.float32), pose.t.astype(np.float32)
    zz = rot[2, 0] * x + rot[2, 1] * y + rot[2, 2] * z + t[2]
    ahead = zz > 0.05
    if not ahead.all():  # usually every point stays in front: no copies then
        x, y, z, zz = x[ahead], y[ahead], z[ahead], zz[ahead]
    xx = rot[0, 0] * x + rot[0, 1] * y + rot[0, 2] * z + t[0]
    yy = rot[1, 0] * x + rot[1, 1] * y + rot[1, 2] * z + t[1]
    # int32 pixel indices: a frame has far fewer than 2**31 pixels.
    uu = np.rint(xx / zz * np.float32(k.fx) + np.float32(k.px)).astype(np.int32)
    vv = np.rint(yy / zz * np.float32(k.fy) + np.float32(k.py)).astype(np.int32)
    inside = (uu >= 0) & (uu < w) & (vv >= 0) & (vv < h)
    flat = np.full(h * w, np.inf, np.float32)  # float32 throughout: minimum.at is 30x slower on a cast
    np.minimum.at(flat, vv[inside] * w + uu[inside], zz[inside])
    out = flat.reshape(h, w)
    empty = np.isinf(out)
    nearest = cv2.erode(np.where(empty, 1e9, out).astype(np.float32), np.ones((3, 3), np.uint8))
    crack = empty & (nearest < 1e8)
    out[crack] = nearest[crack]
    out[np.isinf(out)] = 0
    return out


def fill_from_background(metres: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Holes grown over from their farther side for ``radius`` pixels (what a move uncovers is mostly
    background): each hole pixel within ``radius`` (chessboard distance) of a value takes the farthest
    value within that distance. Returns the filled depth and each pixel's confidence: 1 where it was
    warped, falling linearly to 0 at ``radius`` for filled ones, 0 where still empty."""
    out = metres.astype(np.float32)  # a copy
    hole = out == 0
    conf = (~hole).astype(np.float32)
    if not hole.any() or hole.all():
        return out, conf
    # One dilation with a (2r + 1) square equals r steps of a 3x3 one; the distance sets the confidence.
    dist = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_C, 3)
    far = cv2.dilate(out, np.ones((2 * radius + 1, 2 * radius + 1), np.uint8))
    new = hole & (dist <= radius) & (far > 0)
    out[new] = far[new]
    conf[new] = 1.0 - dist[new] / (radius + 1)
    return out, conf
