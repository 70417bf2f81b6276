"""Ground truth from recordings (paper Section V-C.1 and V-C.2), numpy only.

Two methods, both fed by one streaming pass over the clean static sequence in row stripes, so memory is
bounded by ``memory_mb`` whatever the sequence length (exact medians and quantiles, no float64 stack):

* ``paper``: per-pixel median of the clean sequence; per-pixel mean absolute error of the clean frames
  against it; thresholds mu, mu+sigma, mu+2sigma of that error's distribution give the random-error mask;
  an interfered frame's error mask uses the same threshold; interference = error mask minus random-error
  mask. On the L515 (about 67% zeros, heavy flicker) most pixels are "random error", so it misses a lot.
* ``stats`` (default, ours): per-pixel statistics of the clean sequence (how often the pixel returns, the
  2nd-98th percentile of its returned depths). A pixel of an interfered frame is interference when it
  drops out although the pixel almost always returns, returns although it never does, or returns a depth
  outside its clean range by more than the range noise; then isolated hits are removed, since
  interference comes in bands and clusters, not single pixels.

Ground-truth depth (V-C.2): ``paper`` samples the clean frame with the same position in the sequence;
``stats`` uses the per-pixel median of returned depths (denoised). Outside the mask, pixels where the
input or the reference has no return take the input's value, so zeros do not inflate the RMSE.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.scene.stats import CleanStats, count_from

__all__ = ["METHODS", "THRESHOLDS", "Labeller", "f1", "label_frames"]

METHODS = ("stats", "paper")
THRESHOLDS = ("mu", "mu+sigma", "mu+2sigma")

#: The window (px) ``Labeller.mask`` weighs a raw pixel's neighbours in (``MIN_DENSITY``).
DENSITY_PX = 7
#: A pixel returning in this share of the clean frames is reliable: its dropout is interference.
RELIABLE = 0.9
#: A pixel returning in at most this share seldom returns: a return there is spurious unless near its depth.
RARE = 0.02
#: A raw deviation counts where this share of its ``DENSITY_PX`` window deviates too: interference comes in
#: bands and clusters, a sensor's flicker in single pixels.
MIN_DENSITY = 0.15
#: Inside a clear interference region (twice ``MIN_DENSITY``), a dropout where the pixel returns at least
#: this often is the interference more likely than its own flicker.
LIKELY = 0.45
#: (m, share of the range) beyond a pixel's clean range that a return deviates by.
TOLERANCE = (0.02, 0.01)


class Labeller:
    """Labels interfered frames of the same static view against the clean sequence's statistics."""

    def __init__(
        self,
        stats: CleanStats,
        method: str = "stats",
        threshold: str = "mu+sigma",
        tolerance: tuple[float, float] = TOLERANCE,
    ) -> None:
        """``tolerance``: (m, share of the range) beyond a pixel's clean range that a return deviates by."""
        if method not in METHODS:
            raise ConfigError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
        if threshold not in THRESHOLDS:
            raise ConfigError(f"unknown threshold {threshold!r}; choose from {', '.join(THRESHOLDS)}")
        self.s, self.method, self.threshold = stats, method, threshold
        self.tol_abs, self.tol_rel = tolerance
        e = stats.mean_err
        mu, sd = float(e.mean()), float(e.std())
        self.thr = {"mu": mu, "mu+sigma": mu + sd, "mu+2sigma": mu + 2 * sd}[threshold]
        self.random_error = e > self.thr
        # A DENSITY_PX window's share of raw pixels, as cv2.blur gives it, reaches MIN_DENSITY (or twice
        # it) from these counts on: the integer count then decides as the float share would.
        self._dense_from, self._likely_from = (
            count_from(t, DENSITY_PX) for t in (MIN_DENSITY, 2 * MIN_DENSITY)
        )
        self._limits: dict[str, np.ndarray] = {}
        self.refresh()

    def refresh(self, rows: slice = slice(None)) -> None:
        """Work the per-pixel limits ``mask`` compares a frame with out of the statistics again: all of them,
        or those of ``rows`` after their statistics changed in place (a scene reference's upkeep)."""
        s, lim = self.s, self._limits
        if not lim:
            lim.update({k: np.zeros(s.shape, np.float32) for k in ("tol", "below", "above")})
            flags = ("reliable", "rare", "never", "common", "likely")
            lim.update({k: np.zeros(s.shape, bool) for k in flags})
        rate = s.rate[rows]
        tol = self.tol_abs + self.tol_rel * s.nz_median[rows]
        lim["tol"][rows] = tol
        lim["below"][rows] = s.lo[rows] - tol
        lim["above"][rows] = s.hi[rows] + tol
        lim["reliable"][rows] = rate >= RELIABLE
        lim["rare"][rows] = rate <= RARE
        lim["never"][rows] = rate == 0
        lim["common"][rows] = rate > RARE
        lim["likely"][rows] = rate >= LIKELY

    def mask(self, frame_m: np.ndarray) -> np.ndarray:
        """Boolean interference mask of one frame (metres, 0 = no return)."""
        self._check(frame_m)
        if self.method == "paper":
            s = self.s
            paper: np.ndarray = (np.abs(frame_m - s.median) > self.thr) & ~self.random_error
            return paper
        return self._dense(self._raw(frame_m), frame_m > 0)

    def masks(self, frame_m: np.ndarray, unknown: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(``mask`` of the frame, the same with no return at an ``unknown`` pixel taken as a deviation):
        what changed, and what of it is evidence where the clean sequence does not tell one depth (the
        ``stats`` method)."""
        self._check(frame_m)
        raw, has = self._raw(frame_m), frame_m > 0
        every = self._dense(raw, has)
        drop = raw & has & unknown
        if not drop.any():  # the same mask: one object, which callers may test for
            return every, every
        return every, self._dense(raw & ~drop, has)

    def _check(self, frame_m: np.ndarray) -> None:
        if frame_m.shape != self.s.shape:
            raise InputError(
                f"interfered frame is {frame_m.shape[1]}x{frame_m.shape[0]}, the clean sequence is "
                f"{self.s.shape[1]}x{self.s.shape[0]}"
            )

    def _raw(self, frame_m: np.ndarray) -> np.ndarray:
        """Each pixel that deviates on its own: a dropout where the pixel is reliable, a return where it
        seldom returns far from its depth, a return outside its clean range."""
        s, lim = self.s, self._limits
        has = frame_m > 0
        dropout = ~has & lim["reliable"]
        # A spurious return is one where the scene seldom returns (few pixels): worked out only there.
        spurious = has & lim["rare"]
        at = np.flatnonzero(spurious)
        far = np.abs(frame_m.ravel()[at] - s.nz_median.ravel()[at]) > lim["tol"].ravel()[at]
        spurious.ravel()[at] = lim["never"].ravel()[at] | far
        wrong = has & lim["common"] & ((frame_m < lim["below"]) | (frame_m > lim["above"]))
        raw: np.ndarray = dropout | spurious | wrong
        return raw

    def _dense(self, raw: np.ndarray, has: np.ndarray) -> np.ndarray:
        """The raw deviations amid others, and dropouts of pixels that usually return amid many."""
        count = cv2.boxFilter(raw.view(np.uint8), -1, (DENSITY_PX, DENSITY_PX), normalize=False)
        # Inside a clear interference region, a dropout of a pixel that usually returns is more likely
        # the interference than the pixel's own flicker.
        likely = ~has & self._limits["likely"] & (count >= self._likely_from)
        out: np.ndarray = (raw & (count >= self._dense_from)) | likely
        return out

    def depth(
        self, frame_m: np.ndarray, mask: np.ndarray, reference_m: np.ndarray | None = None
    ) -> np.ndarray:
        """Ground-truth depth (metres): the reference inside the mask, zero-matched to the input outside."""
        ref = self.s.nz_median * (self.s.rate >= 0.5) if self.method == "stats" else reference_m
        if ref is None:
            raise ConfigError("the paper's method samples a clean frame: pass reference_m")
        gt = ref.astype(np.float32).copy()
        out = ~mask & ((frame_m == 0) | (gt == 0))
        gt[out] = frame_m[out]
        return gt


def f1(pred: np.ndarray, true: np.ndarray) -> tuple[float, float, float]:
    """(precision, recall, F1) of boolean masks; 1.0 where there is nothing to find and nothing found."""
    tp = float(np.count_nonzero(pred & true))
    fp = float(np.count_nonzero(pred & ~true))
    fn = float(np.count_nonzero(~pred & true))
    p = tp / (tp + fp) if tp + fp else 1.0
    r = tp / (tp + fn) if tp + fn else 1.0
    return p, r, (2 * p * r / (p + r) if p + r else 0.0)


def label_frames(
    labeller: Labeller,
    frames: Iterable[tuple[str, np.ndarray]],
    depth_scale: float,
    references: Iterator[np.ndarray] | None = None,
) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """(name, mask uint8 255 = interference, ground-truth depth in the input's units) per frame."""
    for name, f in frames:
        fm = f.astype(np.float32) / np.float32(depth_scale)
        ref = None
        if references is not None:
            r = next(references, None)
            ref = None if r is None else r.astype(np.float32) / np.float32(depth_scale)
        m = labeller.mask(fm)
        gt = labeller.depth(fm, m, ref)
        counts = np.clip(np.rint(gt * depth_scale), 0, 65535).astype(np.uint16)
        yield name, m.astype(np.uint8) * 255, counts
