"""Frames the laser skipped, synthesized: the last real depth moved to where the camera is now. Where the
camera went comes from the caller's odometry, or from the colour stream (the real frame's corners tracked
through the colour frames, ``synth.motion``), or is unknown: then the last real frame is held."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from d2sr.config import check_instances, check_whole
from d2sr.errors import InputError
from d2sr.frames.base import Intrinsics
from d2sr.synth.along import fill_along_colour
from d2sr.synth.motion import ColourTrack
from d2sr.synth.warp import (
    Cloud,
    Pose,
    cloud,
    fill_from_background,
    fill_radius,
    guess_intrinsics,
    warp_depth,
)

__all__ = ["METHODS", "Filler", "Synthesized"]

#: How a frame was made: the sensor's own, the caller's poses, the colour stream, the last real frame
#: held, or nothing to go on (no real frame yet).
METHODS = ("real", "warp-pose", "warp-colour", "hold", "none")
HOLD_CONFIDENCE = 0.5  # a held frame is right only where nothing moved: said, not hidden
MAX_RADIUS = 1024  # pixels a hole may be grown over from its background: far beyond any frame's 5% default


@dataclass(frozen=True)
class Synthesized:
    """A frame out of the filler: ``depth`` in metres (float32, 0 = no value), ``confidence`` per pixel in
    [0, 1] (1: the sensor's own or warped from it; lower: filled from the background, held, or carried
    along the colour frame into what the camera newly sees: 0.25, then 0.1), the
    ``method`` that made it and the frames since the last real one."""

    depth: np.ndarray
    confidence: np.ndarray
    method: str
    since_real: int


class Filler:
    """One sensor's synthesis state. Call ``real`` with every frame the laser made and ``synthesize`` for
    every frame it skipped, in time order. ``colour``: the colour frame at the same time (BGR or grey,
    same size as the depth); ``pose``: the camera's pose in the caller's world frame (camera to world);
    ``intrinsics``: the depth camera's (depth aligned to colour), guessed when None; ``radius``: pixels a
    hole is filled from its background side, 0..MAX_RADIUS (None: 5% of the width)."""

    def __init__(self, intrinsics: Intrinsics | None = None, radius: int | None = None) -> None:
        check_instances(intrinsics=(intrinsics, Intrinsics))
        if radius is not None:
            check_whole("radius", radius, 0, MAX_RADIUS)
        self.intrinsics = intrinsics
        self.radius = radius
        self._track: ColourTrack | None = None
        self._source: np.ndarray | None = None  # the last real frame, metres
        self._cloud: Cloud | None = None  # its points, made on its first warp
        self._source_pose: Pose | None = None  # its world pose (odometry)
        self._moved = Pose.identity()  # last real camera -> previous frame's camera
        self._since = 0

    def real(
        self, metres: np.ndarray, colour: np.ndarray | None = None, pose: Pose | None = None
    ) -> Synthesized:
        """A frame the sensor measured: it becomes the source of the next synthesized ones (and comes back
        as it went in, confidence 1 where it has a value)."""
        metres = self._checked(metres)
        colour = _as_colour(colour, metres.shape)
        self._source, self._source_pose, self._cloud = metres, pose, None
        self._moved, self._since = Pose.identity(), 0
        track = self._track_for(metres.shape)
        if colour is None:
            track.clear()
        else:
            track.seed(_grey(colour), metres)
        return Synthesized(metres, (metres > 0).astype(np.float32), "real", 0)

    def synthesize(self, colour: np.ndarray | None = None, pose: Pose | None = None) -> Synthesized:
        """The frame the sensor would have measured now."""
        self._since += 1
        if self._source is None:
            raise InputError("no real frame yet: the filler has nothing to synthesize from")
        source = self._source
        colour = _as_colour(colour, source.shape)
        measured = True
        grey = None if colour is None else _grey(colour)
        if pose is not None and self._source_pose is not None:
            moved, method = self._source_pose.then(pose.inverse()), "warp-pose"
            self._moved = moved  # what a later frame keeps if its colour cannot be measured
        elif grey is not None:
            (moved, measured), method = self._colour_pose(grey), "warp-colour"
        else:
            conf = np.where(source > 0, HOLD_CONFIDENCE, 0).astype(np.float32)
            return Synthesized(source, conf, "hold", self._since)
        k = self._k(source.shape)
        if self._cloud is None:  # every frame synthesized from this real one warps the same points
            self._cloud = cloud(source, k)
        warped = warp_depth(self._cloud, moved, k)
        track = self._track_for(warped.shape)
        if grey is not None and (not track.seeded or (measured and track.thinned)):
            # the real frame came without colour, or half its corners are lost: track from this frame,
            # where the warp put the depth (decisions.md, 2026-11-27)
            track.seed(grey, warped, moved)
        radius = self.radius if self.radius is not None else fill_radius(source.shape[1])
        depth, conf = fill_from_background(warped, radius)
        if colour is not None:  # what the camera newly sees, along the colour frame, at a lower confidence
            depth, conf = fill_along_colour(depth, conf, colour)
        if not measured:  # the camera's step was not seen: where it went is a guess, said as a held frame's
            conf = np.minimum(conf, np.float32(HOLD_CONFIDENCE))
        return Synthesized(depth, conf, method, self._since)

    def _colour_pose(self, grey: np.ndarray) -> tuple[Pose, bool]:
        """Last real camera -> this camera, and whether it was measured: the previous pose again when it
        was not (no colour came with the real frame, or the tracks cannot be trusted). A still camera's
        frame is the real one where it was, not PnP's reading of the colour's noise."""
        step = self._track_for(grey.shape).step(grey)
        if step is None:
            return self._moved, False
        self._moved = step.pose
        return (Pose.identity() if step.still else step.pose), True

    def _track_for(self, shape: tuple[int, ...]) -> ColourTrack:
        if self._track is None:
            self._track = ColourTrack(self._k(shape))
        return self._track

    def _k(self, shape: tuple[int, ...]) -> Intrinsics:
        h, w = shape[:2]
        if self.intrinsics is None:
            self.intrinsics = guess_intrinsics(w, h)
        elif (self.intrinsics.width, self.intrinsics.height) != (w, h):
            self.intrinsics = self.intrinsics.scaled(w, h)
        return self.intrinsics

    def _checked(self, metres: np.ndarray) -> np.ndarray:
        if not isinstance(metres, np.ndarray) or metres.ndim != 2 or metres.dtype.kind not in "fiu":
            shape = getattr(metres, "shape", None)
            raise InputError(f"depth must be a 2-D image of numbers, got shape {shape}")
        return np.where(np.isfinite(metres) & (metres > 0), metres, 0).astype(np.float32)  # else: no return


def _as_colour(colour: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray | None:
    """``colour`` as 8-bit BGR or grey the size of the depth ``shape``; what cannot be read as one is an
    InputError (16-bit images keep their top 8 bits, floats are read in [0, 1], an alpha channel is
    dropped)."""
    if colour is None:
        return None
    if not isinstance(colour, np.ndarray) or colour.ndim not in (2, 3) or colour.dtype.kind not in "fiu":
        raise InputError(f"colour must be an image array, got {getattr(colour, 'shape', colour)!r}")
    if colour.shape[:2] != shape:
        raise InputError(
            f"colour {colour.shape[1]}x{colour.shape[0]} and depth {shape[1]}x{shape[0]} "
            "differ in size: the depth must be aligned to the colour camera"
        )
    if colour.ndim == 3:
        channels = colour.shape[2]
        if channels not in (1, 3, 4):
            raise InputError(f"colour must have 1, 3 or 4 channels, got {channels}")
        colour = colour[..., 0] if channels == 1 else colour[..., :3]
    if colour.dtype == np.uint8:
        return np.ascontiguousarray(colour)
    if colour.dtype == np.uint16:
        return np.ascontiguousarray((colour >> 8).astype(np.uint8))
    if colour.dtype.kind == "f":
        return (np.clip(np.nan_to_num(colour), 0.0, 1.0) * 255).round().astype(np.uint8)
    raise InputError(f"colour must be 8- or 16-bit or floating point, got {colour.dtype}")


def _grey(colour: np.ndarray) -> np.ndarray:
    return colour if colour.ndim == 2 else cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY)
