"""A frame judged against its scene (``Evidence``), and the neighbourhood and motion tests the judgement
uses (numpy and OpenCV only)."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import cv2
import numpy as np

from d2sr.frames.base import crop_around
from d2sr.scene.settings import SceneSettings

if TYPE_CHECKING:
    from d2sr.scene.stats import CleanStats

__all__ = ["HALF", "QUARTER", "Evidence", "SceneRepair"]

AROUND = 81  # pixels in a 9x9 neighbourhood (neighbours)
HALF, QUARTER = math.ceil(AROUND / 2), math.ceil(AROUND / 4)  # counts at or above half, a quarter of it


class SceneRepair(NamedTuple):
    """What a still sensor's scene knows of a frame (``SceneReference.repair``), beside the model's repair."""

    fill: np.ndarray  # bool: pixels whose depth the scene knows within their own noise
    depth: np.ndarray  # float32 metres there (0 elsewhere)
    keep: np.ndarray  # bool: returning pixels the scene finds nothing wrong with: left as they are


class Held(NamedTuple):
    """The reference's state a deferred repair reads, as it was when asked for (``repair_later``)."""

    stored: bool  # the statistics are a stored scene's
    stats: CleanStats
    steady: np.ndarray  # bool: the pixels the scene is sure of
    split: np.ndarray  # bool: the pixels whose clean returns part (no evidence, no offset repair)
    single: np.ndarray  # bool: steady, its and its neighbours' clean returns agree (``flicker_m``)


@dataclass
class Parts:
    """What ``Evidence`` works its fresh shares out from, when first read."""

    settings: SceneSettings
    explain: Callable[[], tuple[np.ndarray, float]]  # -> (fresh, fresh_dense)
    motion: Motion  # what moved since the frame before, worked out once for every kind of deviation
    shift: np.ndarray | None = None  # bool: the shifted windows' pixels
    off: np.ndarray | None = None  # bool: the off windows' pixels
    far: np.ndarray | None = None  # bool: the returns read far off
    # What a deferred repair holds (``SceneReference.repair_later``); empty: ``explain`` reads the reference.
    held: list[Held] = field(default_factory=list)


@dataclass
class Evidence:
    """A frame judged against the scene reference. Shares are of ``known``, the pixels the reference has
    seen return. ``fresh`` (``mask`` less what the frame before's deviations explain: something that moved)
    and the fresh shares are worked out when first read: on most frames ``evident`` needs none of them."""

    mask: np.ndarray  # bool: pixels that deviate as interference would (all False when not ready)
    share: float  # of the known pixels, deviating
    dense: float  # the same counting only pixels amid others (half of their 9x9 neighbourhood)
    ready: bool  # the reference had its warm frames (else the evidence is empty)
    metres: np.ndarray  # the frame judged (float32 metres)
    still: bool = True  # the sensor held still: else the evidence is not to be used
    shifted: float = 0.0  # share in shifted windows (a surface read a little off as a whole)
    off: float = 0.0  # share in off windows (a surface rippled a few centimetres either way)
    far: float = 0.0  # share read far beyond the clean range
    known: int = 1  # pixels the reference has seen return (at least 1)
    parts: Parts | None = field(default=None, repr=False)

    @functools.cached_property
    def _fresh(self) -> tuple[np.ndarray, float]:
        if self.parts is None:
            return np.zeros(self.mask.shape, bool), 0.0
        return self.parts.explain()

    @property
    def fresh(self) -> np.ndarray:
        return self._fresh[0]

    @property
    def fresh_dense(self) -> float:
        return self._fresh[1]

    @property
    def usable(self) -> bool:
        """Evidence a verdict may rest on: the reference is warm and the sensor held still."""
        return self.ready and self.still

    @functools.cached_property
    def fresh_shifted(self) -> float:
        """The share of the known scene in shifted windows that nothing moving explains."""
        if self.parts is None or self.parts.shift is None or not self.shifted:
            return 0.0
        return float(np.count_nonzero(self.fresh & self.parts.shift)) / self.known

    @functools.cached_property
    def fresh_off(self) -> float:
        """The share of the known scene in off windows that nothing moving explains (worked out against the
        frame before on their own, not among ``mask``)."""
        p = self.parts
        if p is None or p.off is None or not self.off:
            return 0.0
        return float(np.count_nonzero(p.motion.unexplained(p.off))) / self.known

    @functools.cached_property
    def fresh_far(self) -> float:
        """The share of the known scene read far off, not explained by something that moved."""
        if not self.far:
            return 0.0
        return float(np.count_nonzero(self.fresh_far_pixels)) / self.known

    @functools.cached_property
    def fresh_far_pixels(self) -> np.ndarray:
        """bool: the returns read far off that nothing moving explains (thin ones need not be among
        ``mask``'s deviations, so they are worked out against the frame before on their own)."""
        p = self.parts
        if p is None or p.far is None or not self.far:
            return np.zeros(self.mask.shape, bool)
        return p.motion.unexplained(p.far)

    @property
    def far_evident(self) -> bool:
        """Fresh far-off returns alone cover ``far_area`` of the scene (one of the ways ``evident`` holds)."""
        return self._covers("far_area", self.far, lambda: self.fresh_far)

    @property
    def shift_evident(self) -> bool:
        """Fresh shifted windows alone cover ``shift_area`` of the scene (a way ``evident`` holds)."""
        return self._covers("shift_area", self.shifted, lambda: self.fresh_shifted)

    def _covers(self, area: str, whole: float, fresh: Callable[[], float]) -> bool:
        """Usable, and one kind of evidence covers the setting ``area`` of the scene, wholly and freshly;
        ``fresh`` is worked out only when ``whole`` does (a fresh share is at most its whole one)."""
        if not self.usable or self.parts is None:
            return False
        mark = getattr(self.parts.settings, area)
        return bool(whole >= mark and fresh() >= mark)

    @property
    def evident(self) -> bool:
        """Fresh dense deviations reach ``evident``, or fresh shifted windows, off windows or far-off returns
        cover their areas: interfered, whatever a detector says (only when ``usable``)."""
        if not self.usable or self.parts is None:
            return False
        mark = self.parts.settings.evident
        if self.dense >= mark and self.fresh_dense >= mark:
            return True
        return (
            self.shift_evident
            or self._covers("off_area", self.off, lambda: self.fresh_off)
            or self.far_evident
        )


def none(shape: tuple[int, ...]) -> Evidence:
    """No evidence (the reference is not warm, rests, or sees another view)."""
    return Evidence(np.zeros(shape, bool), 0.0, 0.0, False, np.zeros(shape, np.float32))


def neighbours(mask: np.ndarray) -> np.ndarray:
    """How many of each pixel's 9x9 neighbourhood (``AROUND``) lie in the bool ``mask``, uint8: a sensor's own
    flicker leaves scattered pixels, interference and moved objects come in patches. Counted in integers
    (a tenth of a float blur's time); ``HALF`` and ``QUARTER`` are the shares the callers ask for."""
    return cv2.boxFilter(mask.view(np.uint8), -1, (9, 9), normalize=False)


def dense(mask: np.ndarray, known: int) -> float:
    """The share of ``known`` pixels amid others in ``mask`` (half of their 9x9 neighbourhood)."""
    return float(np.count_nonzero(neighbours(mask) >= HALF)) / known


class Motion:
    """What moved between a frame (``metres``) and the frame before (``before``: its deviating depths, -1 a
    dropout, 0 none; None: no frame before, nothing to tell motion by), worked out once however many kinds
    of deviation ask (the fresh ones, the far-off and off returns, the scene's rare ones)."""

    def __init__(self, metres: np.ndarray, before: np.ndarray | None, settings: SceneSettings) -> None:
        self.metres, self.before, self.settings = metres, before, settings

    @functools.cached_property
    def _explained(self) -> np.ndarray:
        """bool: every pixel a deviation of the frame before explains (``_reach``)."""
        assert self.before is not None
        return _reach(self.metres, self.before, self.settings)

    @functools.cached_property
    def _moving(self) -> bool:
        return self.before is not None and bool(self.before.any())

    def unexplained(self, mask: np.ndarray) -> np.ndarray:
        """The pixels of ``mask`` nothing that moved explains: none on the first frame judged against a new
        reference (no motion to tell by); ``mask`` itself where nothing deviated a frame before."""
        if self.before is None:
            return np.zeros_like(mask)
        if mask.any() and self._moving:
            out: np.ndarray = mask & ~self._explained
            return out
        return mask


def _reach(metres: np.ndarray, before: np.ndarray, settings: SceneSettings) -> np.ndarray:
    """bool: every pixel a deviation of the frame before within ``motion_px`` explains (read at about its
    depth, or a dropout beside its dropouts)."""
    out = np.zeros(metres.shape, bool)
    reach = settings.motion_px
    # Nothing further than motion_px from the frame before's deviations can be explained: the cost follows
    # them (erode and dilate ignore what lies beyond a crop's edge).
    crop = crop_around(before != 0, reach)
    if crop is None:
        return out
    rs, cs = crop
    b, m = before[rs, cs], metres[rs, cs]
    k = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * reach + 1, 2 * reach + 1))
    lo = cv2.erode(np.where(b > 0, b, np.float32(np.inf)), k)
    hi = cv2.dilate(b, k)
    tol = settings.motion_abs + settings.motion_rel * m
    near = (m > 0) & (m >= lo - tol) & (m <= hi + tol)
    dropped = (m == 0) & (cv2.erode(np.where(b < 0, 0, 1).astype(np.uint8), k) == 0)
    out[rs, cs] = near | dropped
    return out
