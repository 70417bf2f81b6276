"""Camera motion from the colour stream: the last real frame's corners, which have depth, tracked frame to
frame through the colour frames (pyramidal Lucas-Kanade), and each frame's pose found by PnP of the real
frame's own 3-D points on their tracks. No depth is read from a synthesized frame, so errors do not
compound as they did when each step was matched against the previous synthesized frame (ORB, until
0.11; lab/notes/decisions.md, 2026-11-27). Colour keeps streaming while the laser is off, and laser
interference does not touch it."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from d2sr.frames.base import Intrinsics
from d2sr.synth.warp import Pose

__all__ = ["ColourTrack", "Step"]

CORNERS = 600  # tracked from each real frame
MIN_TRACKS = 30  # fewer tracks left than this and the frame is not measured
MIN_INLIERS = 12  # fewer RANSAC inliers than this and the pose is not trusted
FB_PX = 0.5  # a track must come back to where it started within this (forward-backward check)
#: A step between two frames beyond this is a wrong fit, not the camera (4.5 m/s, 300 °/s at 30 fps): a
#: few tracks left on one small patch fit any pose.
MAX_STEP_M, MAX_STEP_DEG = 0.15, 10.0
MOVED_CHI2 = 22.46  # χ² with 6 degrees of freedom, 0.1% point: the motion is seen, not read into noise
#: ... and it moves the tracked points by at least this much (RMS, px). Neighbouring corners share pixels of
#: one noisy image, so their errors are not independent and the test alone over-counts its evidence.
MOVED_PX = 0.05
LK = {"winSize": (21, 21), "maxLevel": 3}
EPS = 1e-9


@dataclass(frozen=True)
class Step:
    """A measured frame: the motion from the last real camera to this one, and whether the tracks show no
    motion at all (``still``: the likelihood ratio of the motion against none below χ²(6)'s 0.1% point,
    or the motion moving them by under ``MOVED_PX``). The test's threshold scales with the tracks: slow
    motion seen by many counts, noise does not."""

    pose: Pose
    still: bool


class ColourTrack:
    """One real frame's corners followed through the colour frames after it. ``seed`` again (from a
    synthesized frame, its depth and pose) when the real frame had no colour or the tracks have ``thinned``.
    """

    def __init__(self, k: Intrinsics) -> None:
        self.k = k
        self.camera = np.array([[k.fx, 0, k.px], [0, k.fy, k.py], [0, 0, 1.0]])
        self.clear()

    def clear(self) -> None:
        """Nothing to track (a real frame came without colour)."""
        self._points: np.ndarray | None = None  # (N, 3) in the real camera's frame
        self._uv = np.zeros((0, 2), np.float32)  # where they are in the previous colour frame
        self._grey: np.ndarray | None = None
        self._pose = Pose.identity()  # real camera -> previous colour frame's camera
        self._pending: tuple[np.ndarray, np.ndarray, Pose] | None = None
        self._n0 = 0  # corners found at the last seed

    @property
    def seeded(self) -> bool:
        return self._points is not None or self._pending is not None

    @property
    def thinned(self) -> bool:
        """Fewer than half of the corners last found are still tracked (or fewer than ``MIN_TRACKS``)."""
        return self._points is not None and len(self._uv) < max(MIN_TRACKS, self._n0 // 2)

    def seed(self, grey: np.ndarray, metres: np.ndarray, pose: Pose | None = None) -> None:
        """Track from this colour frame, whose depth is ``metres`` (same size) and whose camera is ``pose``
        from the real one (None: it is the real one). The corners are found at the first ``step``: most
        real frames are followed by another real one, not a synthesized one."""
        self.clear()
        self._pending = (grey, metres, pose or Pose.identity())

    def step(self, grey: np.ndarray) -> Step | None:
        """This colour frame's camera from the real one, or None when it cannot be trusted (too few tracks or
        inliers, or an impossible step); the next frame is then measured from the last trusted pose."""
        if self._pending is not None:
            self._corners(*self._pending)
        if self._points is None or self._grey is None or len(self._uv) < MIN_INLIERS:
            self._grey = grey
            return None
        prev = self._grey
        nxt, ok, _ = cv2.calcOpticalFlowPyrLK(prev, grey, self._uv, None, **LK)  # type: ignore[call-overload]
        back, ok2, _ = cv2.calcOpticalFlowPyrLK(grey, prev, nxt, None, **LK)  # type: ignore[call-overload]
        good = (ok.ravel() == 1) & (ok2.ravel() == 1) & (np.linalg.norm(back - self._uv, axis=1) < FB_PX)
        self._points, self._uv, self._grey = self._points[good], nxt[good], grey
        if len(self._uv) < MIN_TRACKS:
            return None
        rvec, _ = cv2.Rodrigues(self._pose.R)
        found, rvec, tvec, inliers = cv2.solvePnPRansac(
            self._points, self._uv.astype(np.float64), self.camera, None, rvec.copy(),
            self._pose.t.reshape(3, 1).copy(), useExtrinsicGuess=True, reprojectionError=3.0,
            iterationsCount=100,
        )  # fmt: skip
        if not found or inliers is None or len(inliers) < MIN_INLIERS:
            return None
        rot, _ = cv2.Rodrigues(rvec)
        pose = Pose(rot, tvec.reshape(3))
        step = self._pose.inverse().then(pose)
        turn = np.degrees(np.arccos(np.clip((np.trace(step.R) - 1) / 2, -1, 1)))
        if np.linalg.norm(step.t) > MAX_STEP_M or turn > MAX_STEP_DEG:
            return None
        self._pose = pose
        keep = inliers.ravel()
        return Step(pose, not self._moved(pose, self._points[keep], self._uv[keep].astype(np.float64)))

    def _corners(self, grey: np.ndarray, metres: np.ndarray, pose: Pose) -> None:
        self._pending = None
        self._grey, self._pose = grey, pose
        found = cv2.goodFeaturesToTrack(grey, CORNERS, 0.01, 7)
        if found is None:
            return
        uv = found.reshape(-1, 2)
        h, w = metres.shape
        z = metres[
            np.clip(np.rint(uv[:, 1]).astype(int), 0, h - 1), np.clip(np.rint(uv[:, 0]).astype(int), 0, w - 1)
        ]
        ok = z > 0
        k = self.k
        here = np.stack([(uv[ok, 0] - k.px) * z[ok] / k.fx, (uv[ok, 1] - k.py) * z[ok] / k.fy, z[ok]], axis=1)
        back = pose.inverse()  # this camera -> the real one
        self._points = here @ back.R.T + back.t
        self._n0 = len(here)
        self._uv = uv[ok].astype(np.float32)

    def _moved(self, pose: Pose, points: np.ndarray, uv: np.ndarray) -> bool:
        there, here = self._project(points @ pose.R.T + pose.t), self._project(points)
        ssr_fit, ssr_none = _ssr(there, uv), _ssr(here, uv)
        seen = (2 * len(points) - 6) * np.log(max(ssr_none, EPS) / max(ssr_fit, EPS)) > MOVED_CHI2
        return bool(seen and np.sqrt(_ssr(there, here) / len(points)) >= MOVED_PX)

    def _project(self, points: np.ndarray) -> np.ndarray:
        k = self.k
        z = np.maximum(points[:, 2], EPS)
        return np.stack([k.fx * points[:, 0] / z + k.px, k.fy * points[:, 1] / z + k.py], axis=1)


def _ssr(uv: np.ndarray, img: np.ndarray) -> float:
    return float(((uv - img) ** 2).sum())
