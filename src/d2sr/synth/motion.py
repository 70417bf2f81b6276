"""Camera motion from the colour stream: ORB features of a frame whose depth is known, matched in the next
colour frame, and OpenCV's RANSAC PnP. Colour keeps streaming while the laser is off, and laser
interference does not touch it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from d2sr.frames.base import Intrinsics
from d2sr.synth.warp import Pose

__all__ = ["ColourMotion", "Fit", "Keyframe"]

MIN_INLIERS = 12  # fewer RANSAC inliers than this and the pose is not trusted
RATIO = 0.8  # a match must beat the second best by this ratio
MOVED_CHI2 = 22.46  # χ² with 6 degrees of freedom, 0.1% point: the motion is seen, not read into noise
EPS = 1e-9


@dataclass
class Keyframe:
    """A colour frame with depth: its features and their 3-D points (its camera's frame, metres)."""

    points: np.ndarray  # (N, 3)
    descriptors: np.ndarray  # (N, 32) ORB


#: A fitted motion and its RANSAC inliers: the key's points and their pixels in the other frame.
Fit = tuple[Pose, np.ndarray, np.ndarray]


class ColourMotion:
    """Pose of the current colour frame relative to a keyframe (a frame with depth)."""

    def __init__(self, k: Intrinsics, features: int = 1000) -> None:
        self.k = k
        self.orb = cv2.ORB.create(features)
        self.matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
        self.camera = np.array([[k.fx, 0, k.px], [0, k.fy, k.py], [0, 0, 1.0]])

    def features(self, grey: np.ndarray) -> tuple[Any, np.ndarray | None]:
        """ORB keypoints and descriptors of a grey image, computed once and used twice (``fit`` of this
        frame, then ``keyframe`` for the next)."""
        kps, desc = self.orb.detectAndCompute(grey, None)
        return kps, desc

    def keyframe(self, found: tuple[Any, np.ndarray | None], metres: np.ndarray) -> Keyframe | None:
        """The ``features`` of a frame that have depth in ``metres`` (same size), or None with too few."""
        kps, desc = found
        if desc is None:
            return None
        uv = np.array([kp.pt for kp in kps])
        ui, vi = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
        h, w = metres.shape
        inside = (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
        z = np.zeros(len(kps))
        z[inside] = metres[vi[inside], ui[inside]]
        ok = z > 0
        if ok.sum() < MIN_INLIERS:
            return None
        k = self.k
        pts = np.stack([(uv[ok, 0] - k.px) * z[ok] / k.fx, (uv[ok, 1] - k.py) * z[ok] / k.fy, z[ok]], axis=1)
        return Keyframe(pts, desc[ok])

    def moved(
        self, key: Keyframe, found: tuple[Any, np.ndarray | None], fit: Fit | None = None
    ) -> bool | None:
        """Whether the matches of ``key`` in a frame with ``features`` show the camera moved: the
        likelihood ratio of the fitted motion against none, on its inliers, above χ²(6)'s 0.1% point. A
        test, not a pixel threshold: small motion seen in many matches counts, noise in few does not. None
        when the motion cannot be fitted. ``fit``: ``fit(key, found)`` when the caller has it already."""
        fit = fit if fit is not None else self.fit(key, found)
        if fit is None:
            return None
        pose, obj, img = fit
        ssr_fit = _ssr(self._project(obj @ pose.R.T + pose.t), img)
        ssr_none = _ssr(self._project(obj), img)
        n = len(obj)
        return bool((2 * n - 6) * np.log(max(ssr_none, EPS) / max(ssr_fit, EPS)) > MOVED_CHI2)

    def fit(self, key: Keyframe, found: tuple[Any, np.ndarray | None]) -> Fit | None:
        """The motion from ``key``'s camera to the camera of a frame with ``features`` (RANSAC PnP of the
        key's points on their matches) and its inliers, or None when it cannot be trusted."""
        kps, desc = found
        if desc is None:
            return None
        pairs = self.matcher.knnMatch(key.descriptors, desc, k=2)
        # Lowe's ratio test: one pass instead of a cross-checked two
        matches = [p[0] for p in pairs if len(p) == 2 and p[0].distance < RATIO * p[1].distance]
        if len(matches) < MIN_INLIERS:
            return None
        obj = key.points[[m.queryIdx for m in matches]]
        img = np.array([kps[m.trainIdx].pt for m in matches], np.float64)
        ok, rvec, tvec, inliers = cv2.solvePnPRansac(
            obj, img, self.camera, None, reprojectionError=3.0, iterationsCount=200
        )
        if not ok or inliers is None or len(inliers) < MIN_INLIERS:
            return None
        rot, _ = cv2.Rodrigues(rvec)
        keep = inliers.reshape(-1)
        return Pose(rot, tvec.reshape(3)), obj[keep], img[keep]

    def _project(self, points: np.ndarray) -> np.ndarray:
        k = self.k
        z = np.maximum(points[:, 2], EPS)
        return np.stack([k.fx * points[:, 0] / z + k.px, k.fy * points[:, 1] / z + k.py], axis=1)


def _ssr(uv: np.ndarray, img: np.ndarray) -> float:
    return float(((uv - img) ** 2).sum())
