"""[Retired from src/ in issue 64 (moving_scene failed sealed set J); as it ran at 8577bfa.] A moving sensor's scene reference (numpy and OpenCV only): its last clean frame, warped into each new
frame's view by the camera's pose (odometry the caller gives), and where the new frame's depth deviates from
it. The still sensor's is ``d2sr.reference``.

- Only depth deviations count, where both frames have depth and away from the warped frame's depth edges:
  which returns drop out depends on the view, and what the move uncovered is unknown, not evidence.
- A pixel deviates only if it deviates from each of the last ``frames`` clean frames: interference the
  loop missed becomes a clean frame, and against it alone the next clean frame would deviate.
- A pixel deviates by more than ``TOL_ABS`` + ``TOL_REL`` of its range; a frame's ``dense`` share counts
  deviating pixels amid others (half of a 9x9 neighbourhood), as the still reference does.
- Chosen on the simulator's moving robot with set G's light (docs/research/decisions.md, 2026-11-27). It
  failed sealed set J there: 65% of J's clean frames flagged with drifting odometry, 29% with exact poses
  (two missed frames in a row poison both references). So ``SensorLoop.moving_scene`` is off.
"""

from __future__ import annotations

from collections import deque

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Intrinsics
from d2sr.reference import HALF, Evidence, _neighbours, _none
from d2sr.synth.warp import Cloud, Pose, cloud, guess_intrinsics, warp_depth

__all__ = ["FRAMES", "TOL_ABS", "TOL_REL", "MovingReference"]

#: How far (m, and share of the range) a depth must lie from the warped clean frame's to deviate: the still
#: reference's 5 mm + 0.5% flagged 2.3% of the development sequences' clean frames (the warp's own error).
TOL_ABS, TOL_REL = 0.01, 0.005
#: A warped depth step steeper than this (m, and share of the range, between neighbours) is an edge: a
#: small pose error moves it by a pixel or more, so the pixels around it say nothing.
EDGE_ABS, EDGE_REL = 0.03, 0.03
EDGE_PX = 5
#: Clean frames a pixel must deviate from, each: one missed interfered frame cannot make the next clean
#: frame deviate (with one, 18% of the development sequences' clean frames were flagged after misses).
FRAMES = 2


class MovingReference:
    """``add`` a frame judged clean with its pose (camera to world, ``d2sr.synth.Pose``); ``evidence`` of a
    new frame at its pose. Frames are uint16 in the sensor's units (``depth_scale`` per metre);
    ``intrinsics`` are the depth camera's (guessed from the frame size when None)."""

    def __init__(
        self,
        depth_scale: float,
        intrinsics: Intrinsics | None = None,
        tol_abs: float = TOL_ABS,
        tol_rel: float = TOL_REL,
        frames: int = FRAMES,
    ) -> None:
        if not depth_scale > 0:
            raise ConfigError(f"depth_scale must be positive, got {depth_scale}")
        if frames < 1:
            raise ConfigError(f"frames must be at least 1, got {frames}")
        self.scale, self.intrinsics, self.tol = float(depth_scale), intrinsics, (tol_abs, tol_rel)
        self._last: deque[tuple[Cloud, Pose]] = deque(maxlen=frames)
        self.shape: tuple[int, ...] | None = None

    @property
    def ready(self) -> bool:
        return bool(self._last)

    def reset(self) -> None:
        self._last.clear()

    def _metres(self, frame: np.ndarray) -> np.ndarray:
        if frame.dtype != np.uint16 or frame.ndim != 2:
            raise InputError(f"a scene reference takes uint16 depth frames, got {frame.dtype} {frame.shape}")
        if self.shape is not None and frame.shape != self.shape:
            raise InputError(f"frame is {frame.shape}, the reference's frames are {self.shape}")
        self.shape = frame.shape
        if self.intrinsics is None:
            self.intrinsics = guess_intrinsics(frame.shape[1], frame.shape[0])
        return frame.astype(np.float32) / np.float32(self.scale)

    def add(self, frame: np.ndarray, pose: Pose) -> None:
        """A frame judged clean, taken at ``pose``: what the next frames are judged against."""
        metres = self._metres(frame)
        assert self.intrinsics is not None
        self._last.append((cloud(metres, self.intrinsics), pose))

    def evidence(self, frame: np.ndarray, pose: Pose) -> Evidence:
        """The frame, taken at ``pose``, judged against the last clean frames seen from there. ``fresh`` is
        ``mask``: with no scene statistics there is no telling a moved object by its history."""
        metres = self._metres(frame)
        if not self._last:
            return _none(frame.shape)
        assert self.intrinsics is not None
        mask, both = metres > 0, metres > 0
        kernel = np.ones((EDGE_PX, EDGE_PX), np.uint8)
        for points, at in self._last:
            seen = warp_depth(points, at.then(pose.inverse()), self.intrinsics)
            both = both & (seen > 0)
            step = cv2.morphologyEx(seen, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))
            edge = cv2.dilate((step > EDGE_ABS + EDGE_REL * seen).view(np.uint8), kernel) > 0
            mask &= (seen > 0) & ~edge & (np.abs(metres - seen) > self.tol[0] + self.tol[1] * seen)
        known = max(int(np.count_nonzero(both)), 1)
        share = float(np.count_nonzero(mask)) / known
        dense = float(np.count_nonzero(_neighbours(mask) >= HALF)) / known
        return Evidence(mask, share, dense, True, metres, lambda: (mask, dense))
