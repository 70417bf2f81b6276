"""A still sensor's scene reference, kept online (numpy only): per-pixel statistics of the frames it judged
clean (``d2sr.scene.stats``), and each new frame judged against them (``Evidence``).

Interference that reads as a plausible surface (a patch shifted a few centimetres, a smooth swing) cannot be
told from the scene inside one frame; against what this sensor has seen of its scene it can. A frame's
evidence is the pixels that deviate as interference would: a reliable pixel dropping out, a never-returning
one returning, a depth outside the pixel's clean range, in clusters; windows of a surface read off as a
whole (shifted) or rippled both ways (off); returns far beyond the clean range. What moved since the frame
before explains a deviation (``Evidence.fresh`` leaves it out); interference flickers. A pixel that deviates
for ``persist`` frames in a row is the scene now; a camera that moved starts the scene again. Every number
is a ``SceneSettings`` field with its reason; the measurements are in ``lab/notes/scene-reference.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections import deque
from collections.abc import Callable

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import crop_around, to_metres
from d2sr.scene.evidence import (
    HALF,
    QUARTER,
    Evidence,
    Held,
    Motion,
    Parts,
    SceneRepair,
    dense,
    neighbours,
    none,
)
from d2sr.scene.labeller import Labeller
from d2sr.scene.settings import SceneSettings
from d2sr.scene.stats import STAT_FIELDS, CleanStats, blur_shares, count_from, stack_stats
from d2sr.scene.stored import StoredScene

__all__ = ["SceneReference"]

#: The statistics the evidence and the repair read, refreshed stripe by stripe (``median`` and ``mean_err``
#: are ``d2sr label``'s, for the paper's method only: a reference keeps them at 0).
READ = ("rate", "nz_median", "lo", "hi", "gap")


class SceneReference:
    """Per-pixel scene statistics of one still sensor, from the frames ``add`` is given (those judged clean),
    and each new frame's ``evidence`` against them. Frames are uint16 in the sensor's units."""

    _stats: CleanStats | None  # None until warm
    _labeller: Labeller | None
    _streak: np.ndarray | None  # per pixel, frames in a row it has deviated
    # A pixel whose clean frames read two depths, apart by more than its own noise (``trust_abs``,
    # ``trust_rel``), each in ``split_part`` of them or more, is parted: interference the detector passed,
    # repeating at one place. It tells no surface: its median may be the interference's or lie between the
    # two, and either may be the clean one. Interference comes in patches: a pixel amid parted ones (a
    # quarter of its 9x9) is split too, though its few returns agreed.
    _gap: np.ndarray  # float32 m: the clean returns' widest gap (``stack_stats``), once warm
    _parted: np.ndarray  # bool, once warm
    _split: np.ndarray  # bool: parted, or amid parted pixels; their returns are no evidence
    _steady: np.ndarray  # bool: pixels the scene is sure of (``trust_rate``, not split), once warm
    _single: np.ndarray  # bool: steady, no gap beyond ``flicker_m`` between its or its neighbours' returns
    _shift_px: np.ndarray  # bool: pixels shifted windows are worked out over (``shift_rate``), once warm
    _far_lo: np.ndarray  # a return below this is far off, once warm (``_limits``)
    _far_hi: np.ndarray  # and above this
    _returned: np.ndarray  # per row, pixels it has seen return, once warm
    _known: int  # their sum (at least 1)

    def __init__(self, depth_scale: float, settings: SceneSettings | None = None) -> None:
        if not depth_scale > 0:
            raise ConfigError(f"depth_scale must be positive, got {depth_scale}")
        self.settings = settings if settings is not None else SceneSettings()
        self.scale = float(depth_scale)
        self._naps = 0  # restarts because the view changed since the gate was last open
        self._ring: np.ndarray | None = None
        self._lent = False  # a deferred repair holds the statistics as they are (``repair_later``)
        self.reset()

    @classmethod
    def from_stored(cls, stored: StoredScene, settings: SceneSettings | None = None) -> SceneReference:
        """A reference that starts from a stored scene (``d2sr scene learn``), warm at once. Its statistics
        stay the stored ones: new clean frames do not re-summarize them, but a pixel that deviates for
        ``persist`` frames in a row still takes its new value (a chair moved), and a view that changed starts
        the scene again from the frames, as a reference that was never stored would."""
        ref = cls(stored.depth_scale, settings)
        h, w = stored.shape
        ref._ring = np.zeros((ref.settings.frames, h, w), np.uint16)
        ref.count = min(stored.frames, ref.settings.frames)
        ref._stored = True
        s = stored.stats
        ref._start((h, w), CleanStats(**{k: np.array(getattr(s, k)) for k in STAT_FIELDS}, frames=s.frames))
        return ref

    def reset(self) -> None:
        """Forget the scene (the next ``warm`` clean frames build it again)."""
        self.count = 0  # clean frames in the ring (at most ``frames``)
        self._next = 0  # ring slot the next clean frame goes to
        self._stripe = 0  # stripe of rows the next ``add`` re-summarizes
        self._stats, self._labeller, self._streak, self._moving = None, None, None, 0
        self._before: np.ndarray | None = None  # the frame before's deviating depths (m; -1: a dropout)
        self._prev: np.ndarray | None = None  # the frame before as judged (m), all of it
        self._judged: float | None = None  # the share the last frame judged deviated by (None: not judged)
        self._resting = 0  # frames the scene still rests (``rest``)
        self._skip = False  # the last frame judged came while resting: ``add`` keeps nothing
        self._clean: deque[float] = deque(maxlen=self.settings.still_frames)  # those then taken as clean
        self._stored = False  # the statistics are a stored scene's (``from_stored``): not re-summarized

    @property
    def still(self) -> bool:
        """The sensor held still, as its scene sees it (``still_share``): its evidence may be used."""
        s = self.settings
        if s.still_share is None:
            return True
        return len(self._clean) >= s.still_min and _quantile(self._clean, s.still_q) <= s.still_share

    @property
    def settled(self) -> bool:
        """Warm, still, and not resting or restarted since its gate last opened: a scene the sensor held
        still for (what ``SensorLoop.prime`` keeps)."""
        return self.ready and self.still and self._resting == 0 and self._naps == 0

    @property
    def shape(self) -> tuple[int, ...] | None:
        """The frames' shape (None before the first)."""
        return None if self._ring is None else self._ring.shape[1:]

    @property
    def ready(self) -> bool:
        return self._labeller is not None

    @property
    def rates(self) -> np.ndarray | None:
        """Per pixel, the share of the clean frames it returned in (None until warm)."""
        return None if self._stats is None else self._stats.rate

    def _check(self, frame: np.ndarray) -> None:
        if frame.dtype != np.uint16 or frame.ndim != 2:
            raise InputError(f"a scene reference takes uint16 depth frames, got {frame.dtype} {frame.shape}")
        if self._ring is not None and frame.shape != self._ring.shape[1:]:
            raise InputError(f"frame is {frame.shape}, the reference's frames are {self._ring.shape[1:]}")

    def add(self, frame: np.ndarray) -> None:
        """A frame judged clean: into the ring, and one stripe of the statistics refreshed (not while the
        scene rests)."""
        self._check(frame)
        if self._skip:
            return
        if self._judged is not None:
            self._clean.append(self._judged)
            self._judged = None
        size = self.settings.frames
        if self._ring is None:
            self._ring = np.zeros((size, *frame.shape), np.uint16)
        self._ring[self._next] = frame
        self._next = (self._next + 1) % size
        self.count = min(self.count + 1, size)
        if self.count < self.settings.warm or self._stored:
            return
        if self._stats is None:  # just warm: every stripe at once
            ring = stack_stats(self._ring[: self.count], READ, self.settings.split_part)
            full = _metres(ring, self.scale)  # one sort of the ring for both
            gap = full.pop("gap")
            unread = {k: np.zeros(frame.shape, np.float32) for k in STAT_FIELDS if k not in full}
            self._start(frame.shape, CleanStats(frames=self.count, **full, **unread), gap)
            return
        self._own()
        stripes = self.settings.stripes
        rows = -(-frame.shape[0] // stripes)
        r0 = self._stripe * rows
        r1 = min(frame.shape[0], r0 + rows)
        part = stack_stats(self._ring[: self.count, r0:r1], READ, self.settings.split_part)
        fresh = _metres(part, self.scale)
        self._gap[r0:r1] = fresh.pop("gap")
        for name, v in fresh.items():
            getattr(self._stats, name)[r0:r1] = v
        self._limits(slice(r0, r1), labeller=True)
        self._stripe = (self._stripe + 1) % stripes

    def _start(self, shape: tuple[int, ...], stats: CleanStats, gap: np.ndarray | None = None) -> None:
        """The scene's statistics (of the first ``warm`` clean frames, or stored: learned clean, no gaps) and
        their returns' ``gap`` (``stack_stats``, metres), and the limits read from them."""
        s = self.settings
        self._stats, self._lent = stats, False
        self._gap = gap if gap is not None else np.zeros(shape, np.float32)
        self._labeller = Labeller(self._stats, tolerance=(s.tol_abs, s.tol_rel))
        self._parted = np.zeros(shape, bool)
        self._split = np.zeros(shape, bool)
        self._steady = np.zeros(shape, bool)
        self._single = np.zeros(shape, bool)
        # At trust_rate the shifted windows' pixels are the steady ones: the same array, kept once.
        self._shift_px = self._steady if s.shift_rate == s.trust_rate else np.zeros(shape, bool)
        self._far_lo = np.zeros(shape, np.float32)
        self._far_hi = np.zeros(shape, np.float32)
        self._returned = np.zeros(shape[0], np.int64)
        self._limits()  # the labeller worked its own out as it was made
        self._streak = np.zeros(shape, np.uint16)

    def _own(self) -> None:
        """Before the statistics a deferred repair reads change in place: give the reference copies of its
        own, so the repair still reads them as they were when it was asked for (``repair_later``)."""
        if not self._lent:
            return
        s, labeller = self._stats, self._labeller
        assert s is not None and labeller is not None
        self._stats = labeller.s = dataclasses.replace(
            s, rate=s.rate.copy(), nz_median=s.nz_median.copy(), lo=s.lo.copy(), hi=s.hi.copy()
        )
        same = self._shift_px is self._steady
        self._steady, self._split, self._single = self._steady.copy(), self._split.copy(), self._single.copy()
        if same:
            self._shift_px = self._steady
        self._lent = False

    def _limits(self, rows: slice = slice(None), labeller: bool = False) -> None:
        """The per-pixel limits the evidence compares a frame with, worked out again where the statistics
        changed: the steady pixels, where a return reads far off, and (``labeller``) the labeller's."""
        s, cfg = self._stats, self.settings
        assert s is not None and self._labeller is not None
        if labeller:
            self._labeller.refresh(rows)
        median = s.nz_median[rows]
        self._parted[rows] = (self._gap[rows] > cfg.trust_abs + cfg.trust_rel * median) & (median > 0)
        # The split pixels, which the parted ones decide within their 9x9 neighbourhoods (beyond the stripe).
        start = rows.start or 0
        near = slice(max(start - 4, 0), None if rows.stop is None else rows.stop + 4)
        top = start - near.start
        parted = self._parted[near]
        split = (parted | (neighbours(parted) >= QUARTER))[top : top + len(median)]
        self._split[rows] = split
        agree = ~split & (median > 0)
        self._steady[rows] = (s.rate[rows] >= cfg.trust_rate) & agree
        wide = self._gap[near] > cfg.flicker_m  # the same way, at the flicker a live scene tells
        loose = (wide | (neighbours(wide) >= QUARTER))[top : top + len(median)]
        self._single[rows] = self._steady[rows] & ~loose
        if self._shift_px is not self._steady:
            self._shift_px[rows] = (s.rate[rows] >= cfg.shift_rate) & agree
        self._returned[rows] = np.count_nonzero(s.rate[rows] > 0, axis=1)  # per row: pixels seen returning
        # A return is far off only where the scene returns at least range_rate of the time, at one depth
        # (+-inf elsewhere).
        tol = cfg.far_abs + cfg.far_rel * s.nz_median[rows]
        often = (s.rate[rows] >= cfg.range_rate) & ~split
        self._far_lo[rows] = np.where(often, s.lo[rows] - tol, -np.inf)
        self._far_hi[rows] = np.where(often, s.hi[rows] + tol, np.inf)
        self._known = max(int(self._returned.sum()), 1)

    def evidence(self, frame: np.ndarray, metres: np.ndarray | None = None) -> Evidence:
        """The frame judged against the reference; also what keeps the reference current (lasting change
        taken in, a moved camera noticed), so call it once per frame, in order. ``metres``: the frame as
        ``to_metres(frame, scale)`` gives it, where the caller has it already."""
        self._check(frame)
        self._judged = None
        self._skip = self._resting > 0  # resting: this frame is judged and kept by nothing
        if self._skip:
            self._resting -= 1
            return none(frame.shape)
        if self._labeller is None or self._stats is None or self._streak is None:
            return none(frame.shape)
        cfg = self.settings
        metres = to_metres(frame, self.scale) if metres is None else metres
        seen, deviates = self._labeller.masks(metres, self._split)
        known = self._known
        share = float(np.count_nonzero(seen)) / known
        if self._view_changed(share):
            return none(frame.shape)
        if share > cfg.elsewhere:  # another view: no evidence
            return none(frame.shape)
        if self._stored and not self._clean and cfg.still_share is not None and share <= cfg.still_share:
            # A stored scene's first frame that matches it shows the sensor where it was learned, held
            # still: the gate opens on it, not on the first frame the detector passes (which may be late).
            self._clean.append(share)
        still = self.still  # as the frames before this one showed
        if still:
            self._naps = 0
        self._judged = share
        shift, off_px = self._shifted(metres)
        # Every deviation tells what moved and what lasts; a return where the scene knows no one depth (split)
        # is no evidence of interference, nor a dropout amid such returns.
        changed = seen | shift
        mask = deviates | shift
        near = neighbours(deviates)
        dense_share = float(np.count_nonzero(near >= HALF)) / known  # flicker is scattered, interference not
        before = self._before
        # A live scene tells the CW-ToF kind of interference from a thing on its surface only once its ring
        # is full: a young one's medians may still hold the frames the detector passed.
        prev, self._prev = self._prev, metres
        full = self.count >= cfg.frames
        held: list[Held] = []  # set by repair_later: what it holds
        motion = Motion(metres, before, cfg)

        def explain() -> tuple[np.ndarray, float]:
            fresh = motion.unexplained(mask)
            if fresh is mask:  # nothing explained: its dense share is the frame's
                return mask, dense_share
            assert self._stats is not None
            h = held[0] if held else self._held()
            if h.stored:
                fresh = fresh | (mask & _on_surface(metres, h.stats, h.steady, cfg))
            elif full and prev is not None:
                fresh = _flickering(metres, prev, mask, fresh, h, cfg)
            return fresh, dense(fresh & deviates, known)

        # Where nothing split or shifted, ``changed`` is ``deviates``: its neighbours are counted already.
        alike = seen is deviates and not shift.any()
        self._before = _explains(metres, changed, near if alike else neighbours(changed))
        self._keep_lasting(frame, changed)
        far_off = (metres > 0) & ((metres < self._far_lo) | (metres > self._far_hi))
        parts = Parts(cfg, explain, motion, shift, off_px, far_off, held)
        return Evidence(
            mask,
            share,
            dense_share,
            True,
            metres,
            still,
            shifted=float(np.count_nonzero(shift)) / known,
            off=float(np.count_nonzero(off_px)) / known if off_px is not None else 0.0,
            far=float(np.count_nonzero(far_off)) / known,
            known=known,
            parts=parts,
        )

    def _view_changed(self, share: float) -> bool:
        """Count a frame deviating like another view (beyond ``moved``, or ``elsewhere``); after
        ``moved_frames`` in a row, start the scene again and rest, longer each time until the gate opens."""
        cfg = self.settings
        self._moving = self._moving + 1 if share > min(cfg.moved, cfg.elsewhere) else 0
        if self._moving < cfg.moved_frames:
            return False
        self.reset()
        if cfg.rest:
            self._resting = min(cfg.rest << min(self._naps, 16), max(cfg.rest_max, cfg.rest))
            self._naps += 1
            self._skip = True  # this frame, of the view that moved, is not kept either
        return True

    def _keep_lasting(self, frame: np.ndarray, mask: np.ndarray) -> None:
        """Count each pixel's deviations in a row; those at ``persist`` are the scene now."""
        assert self._streak is not None
        self._streak += 1  # in place: at most ``persist`` (``_take`` clears it there)
        self._streak *= mask
        lasting = self._streak >= self.settings.persist
        if lasting.any():
            self._take(frame, lasting)

    def _shifted(self, metres: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Pixels returning in ``shift_rate`` of the clean frames in a ``shift_px`` window of them whose mean
        difference from the scene is beyond ``shift_m``, themselves that far off the same way: a surface read
        a few centimetres off, within each pixel's tolerance but not the window's. Also the off windows'
        pixels (``off_m``), once the ring is full (else None)."""
        s, cfg = self._stats, self.settings
        assert s is not None
        side, cap = cfg.shift_px, 3 * cfg.shift_m
        px = self._steady if self.count < cfg.frames else self._shift_px
        steady = (metres > 0) & px
        diff = np.subtract(metres, s.nz_median, dtype=np.float32)
        diff *= steady  # 0 (or -0, the same to every use below) off the steady returns
        clipped = np.clip(diff, -cap, cap)  # one far-off pixel cannot shift a window
        count = cv2.boxFilter(steady.view(np.uint8), -1, (side, side), normalize=False)
        total = cv2.blur(clipped, (side, side))
        # Only a steady pixel that reads that far off itself, amid at least half steady ones, can be shifted:
        # the window's mean is worked out there alone (its share as cv2.blur gives it, from the count).
        amid = count >= count_from(0.5, side)
        size = np.abs(diff)  # 0 off the steady returns
        own = steady & (size > cfg.shift_m) & amid
        at = np.flatnonzero(own)
        n = blur_shares(side)[count.ravel()[at]]
        mean = total.ravel()[at] / np.maximum(n, np.float32(1e-6))
        out = np.zeros(metres.shape, bool)
        # The window reads off, and the pixel itself as far and the same way (not merely next to it).
        out.ravel()[at] = (np.abs(mean) > cfg.shift_m) & (diff.ravel()[at] * mean > 0)
        if self.count < cfg.frames:
            return out, None
        # Off windows, against the median of a full ring only (a young scene's medians wander by centimetres):
        # at least half the window's steady pixels read beyond off_m either way, the pixel itself too (counted
        # in integers: a float share costs more than the window sums).
        far = size > cfg.off_m
        n_far = cv2.boxFilter(far.view(np.uint8), -1, (side, side), normalize=False)
        off = far & amid & (n_far >= ((count + 1) >> 1))
        return out, off

    def repair(self, ev: Evidence) -> SceneRepair:
        """What the scene knows of ``ev``'s frame. Where the reference is trusted (``trust_rate``,
        ``trust_abs``, ``trust_rel``), its own depth for the fresh deviations in patches, for each fresh
        far-off return of a frame they flag, and for such returns in patches where it seldom returns; a
        surface shifted as a whole gets its own depth less its offset (``fill``). Outside the deviations, a
        returning pixel that reads within the range the scene has seen it at, or where the scene seldom
        returns near the depth it did, is left as it is (``keep``): a model's guess could only do harm.
        Nothing when not usable."""
        return self.repair_later(ev)()

    def repair_later(self, ev: Evidence) -> Callable[[], SceneRepair]:
        """``repair`` of ``ev``'s frame, worked out when the returned function is called: later and on another
        thread, while the next frames are judged (``SensorLoop.finish``). It reads the statistics as they
        are now; the reference copies them before it next changes them."""
        if self._stats is None or not ev.usable:
            return functools.partial(_nothing, ev.mask.shape)
        self._lent = True
        h = self._held()
        if ev.parts is not None and not ev.parts.held:
            ev.parts.held.append(h)
        return functools.partial(_repair, ev, h, self.settings)

    def _held(self) -> Held:
        """The state the evidence and a repair read, as it is now (copied before it changes: ``_own``)."""
        assert self._stats is not None
        return Held(self._stored, self._stats, self._steady, self._split, self._single)

    def _take(self, frame: np.ndarray, where: np.ndarray) -> None:
        """Pixels that have deviated for ``persist`` frames: their new value is the scene now."""
        assert self._ring is not None and self._stats is not None and self._streak is not None
        self._own()
        self._ring[:, where] = frame[where]
        v = frame[where].astype(np.float32) / np.float32(self.scale)
        s = self._stats
        s.median[where] = v
        s.nz_median[where] = s.lo[where] = s.hi[where] = v
        s.rate[where] = (v > 0).astype(np.float32)
        s.mean_err[where] = 0
        self._gap[where] = 0
        self._streak[where] = 0
        self._limits(labeller=True)


def _on_surface(metres: np.ndarray, s: CleanStats, steady: np.ndarray, cfg: SceneSettings) -> np.ndarray:
    """Returns within ``offset_cap`` of a stored scene's depth where it nearly always returns (``steady``):
    the same surface read a few centimetres off, which nothing that moved explains. A stored scene was
    learned clean and is not re-summarized from the frames it judges, so a persistent offset from it is the
    CW-ToF kind of interference (a real Kinect v2 beside two others reads its target's face 2-5 cm off,
    frame after frame, varying in sign and size), not the scene's own drift."""
    off = np.abs(np.subtract(metres, s.nz_median, dtype=np.float32))
    out: np.ndarray = (metres > 0) & (off <= np.float32(cfg.offset_cap)) & steady
    return out


def _flickering(
    metres: np.ndarray, prev: np.ndarray, mask: np.ndarray, fresh: np.ndarray, h: Held, cfg: SceneSettings
) -> np.ndarray:
    """``fresh`` and the deviations of ``mask`` it left out (the frame before explained them) that lie on a
    live scene's surface (within ``offset_cap`` of its median where the scene is ``single``) amid returns
    that changed by more than ``flicker_m`` since the frame before (``prev``, metres), on the mean over a
    ``shift_px`` window: something that moved here reads as it did or lies off the surface; another CW-ToF
    camera's light reads the same surface off by an amount that changes frame to frame, a patch at a time
    (a window's mean is known to a millimetre where each pixel's own noise spans centimetres). Where clean
    returns part by more, the scene may hold interference repeating at one place, its median between two
    depths, and a clean return changes as much."""
    left = mask & ~fresh
    crop = crop_around(left, cfg.shift_px // 2)
    if crop is None:
        return fresh
    rs, cs = crop
    m, p = metres[rs, cs], prev[rs, cs]
    both = (m > 0) & (p > 0) & h.single[rs, cs]
    # The tests per pixel first, on the few left out; the windows' sums are gathered there alone.
    at = np.flatnonzero(left[rs, cs] & both)
    off = np.abs(np.subtract(m.ravel()[at], h.stats.nz_median[rs, cs].ravel()[at], dtype=np.float32))
    at = at[off <= np.float32(cfg.offset_cap)]
    if at.size == 0:
        return fresh
    change = np.subtract(m, p, dtype=np.float32)
    change *= both
    k = (cfg.shift_px, cfg.shift_px)  # a count of at most 15 x 15 = 225: uint8 holds it
    n = cv2.boxFilter(both.view(np.uint8), -1, k, normalize=False).ravel()[at]
    mean = cv2.boxFilter(change, -1, k, normalize=False).ravel()[at] / np.maximum(n, 1).astype(np.float32)
    at = at[np.abs(mean) > np.float32(cfg.flicker_m)]
    out = fresh.copy()
    width = m.shape[1]
    out[rs.start + at // width, cs.start + at % width] = True
    return out


def _nothing(shape: tuple[int, ...]) -> SceneRepair:
    """A scene repair that knows nothing: no reference yet, or the sensor moved."""
    empty = np.zeros(shape, bool)
    return SceneRepair(empty, np.zeros(shape, np.float32), empty)


def _repair(ev: Evidence, h: Held, cfg: SceneSettings) -> SceneRepair:
    """``SceneReference.repair``'s work on the state it was given (``repair_later``)."""
    s, m = h.stats, ev.metres
    # A return where the scene's clean depths agree is trusted from range_rate: it did return, and the
    # scene says where; a dropout only where the scene nearly always returns (trust_rate).
    rate = np.where(m > 0, np.float32(cfg.range_rate), np.float32(cfg.trust_rate))
    trusted = (s.rate >= rate) & (s.hi - s.lo <= cfg.trust_abs + cfg.trust_rel * s.nz_median)
    trusted &= s.nz_median > 0
    near = neighbours(ev.fresh)
    # Fresh deviations in patches; where the scene nearly always returns (steady), sparser ones too.
    patches = (near >= HALF) | ((near >= QUARTER) & h.steady)
    where = ev.fresh & patches & trusted
    far_frame = ev.far_evident
    if far_frame:
        # Each return read far beyond where the scene returns half the time or more (so it has a depth
        # there), in a frame with more such returns than the sensor's own flicker makes: interference.
        where |= ev.fresh_far_pixels
    tol = cfg.tol_abs + cfg.tol_rel * s.nz_median
    within = (m >= s.lo - tol) & (m <= s.hi + tol)
    seldom = s.rate < cfg.range_rate
    far_from_seen = np.abs(m - s.nz_median) > cfg.far_abs + cfg.far_rel * s.nz_median
    seldom &= (s.rate == 0) | ~far_from_seen  # where it seldom returns, only near where it did
    if far_frame:
        # Where it seldom returns but did, a fresh return far from that depth, amid a quarter of such
        # returns and far-off ones: the sensor's own stray returns there come alone or a few together.
        rare = (m > 0) & (s.rate > 0) & (s.rate < cfg.range_rate) & far_from_seen
        rare = ev.parts.motion.unexplained(rare) if ev.parts else np.zeros_like(rare)
        rare &= neighbours(rare | ev.fresh_far_pixels) >= QUARTER
        where |= rare
    keep = (m > 0) & ~ev.mask & (seldom | within)
    depth = np.where(where, s.nz_median, 0).astype(np.float32)
    if ev.shift_evident:
        at, by = _offsets(ev, s, where, cfg, h.split)
        where, keep = where | at, keep & ~at
        depth[at] = m[at] - by[at]
    return SceneRepair(where, depth, keep)


def _explains(metres: np.ndarray, mask: np.ndarray, near: np.ndarray) -> np.ndarray:
    """What explains the next frame's deviations: this one's in patches (a moved object), not flicker; their
    depths, -1 a dropout, written where they are (patches are few)."""
    at = np.flatnonzero(mask & (near >= QUARTER))
    out = np.zeros_like(metres)
    depth = metres.ravel()[at]
    out.ravel()[at] = np.where(depth > 0, depth, np.float32(-1))
    return out


def _offsets(
    ev: Evidence, s: CleanStats, filled: np.ndarray, cfg: SceneSettings, split: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(bool: returns of a surface shifted as a whole, float32: their window's mean offset in metres). A
    window's mean over a hundred-odd pixels is known to a few millimetres where each pixel's own noise spans
    centimetres. A return amid such a surface (windows whose fresh shifted pixels are a quarter of the window
    and half of its returns) that reads off the same way, by at least half the mean, takes its own depth
    less the mean; where the scene's fill (``filled``) writes its median, only if the offsets agree (spread
    within ``shift_m``) and are within ``offset_cap``; never where the scene is ``split``."""
    m = ev.metres
    has = (m > 0) & (s.rate >= cfg.range_rate) & (s.nz_median > 0) & ~split
    diff = np.subtract(m, s.nz_median, dtype=np.float32)
    diff *= has  # products, not np.where: a third of the time on scattered masks
    assert ev.parts is not None and ev.parts.shift is not None  # a shift-evident frame has shifted windows
    shifted = ev.fresh & ev.parts.shift
    side = cfg.shift_px
    k = (side, side)
    n = cv2.boxFilter(shifted.view(np.uint8), cv2.CV_32F, k, normalize=False)  # at most side squared
    within = cv2.boxFilter(has.view(np.uint8), cv2.CV_32F, k, normalize=False)
    part = diff * shifted
    count = np.maximum(n, np.float32(1))
    mean = cv2.boxFilter(part, -1, k, normalize=False) / count
    spread = cv2.boxFilter(part * part, -1, k, normalize=False) / count - mean * mean
    whole = (n >= np.float32(side * side / 4)) & (2 * n >= within)
    alike = (diff * mean > 0) & (np.abs(diff) >= np.float32(0.5) * np.abs(mean))
    agree = (np.abs(mean) <= cfg.offset_cap) & (spread <= np.float32(cfg.shift_m * cfg.shift_m))
    return has & whole & alike & (~filled | agree), mean


def _quantile(values: deque[float], q: float) -> float:
    """``np.quantile(values, q)`` (its linear method, the same float64 arithmetic) of a few values, without
    numpy's overhead (a tenth of a millisecond a frame)."""
    v = sorted(values)
    at = q * (len(v) - 1)
    i = min(math.floor(at), len(v) - 1)
    a, b, t = v[i], v[min(i + 1, len(v) - 1)], at - i
    return b - (b - a) * (1 - t) if t >= 0.5 else a + (b - a) * t


def _metres(part: dict[str, np.ndarray], scale: float) -> dict[str, np.ndarray]:
    """``stack_stats``' depths in metres (``rate`` is a share)."""
    return {k: v if k == "rate" else v / np.float32(scale) for k, v in part.items()}
