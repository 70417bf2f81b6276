"""A still sensor's scene reference, kept online (numpy only): per-pixel statistics of the frames it judged
clean, the same statistics ``d2sr label`` judges interference by (``labels.CleanStats``, ``labels.Labeller``).

Interference that reads as a plausible surface (a patch shifted a few centimetres, a smooth swing) cannot be
told from the scene inside one frame; against what this sensor has seen of its scene it can. ``evidence``
says which pixels of a frame deviate from the reference as interference would (a reliable pixel dropping
out, a never-returning one returning, a depth outside the pixel's clean range by more than the range noise,
in clusters) and what share of the scene they cover.

- A surface read a little off as a whole: a window of steady pixels whose mean reads more than ``SHIFT_M`` off
  deviates, though each pixel may lie within its own noise (a CW-ToF camera's light, set G); fresh such
  windows over ``SHIFT_AREA`` of the scene flag the frame (judged on sealed set M), and the repair then gives
  each return of such a surface its own depth less the window's offset (sealed set AC).
- A surface rippled or blotched a few centimetres both ways, whose window mean stays about right: a window
  at least half of whose steady pixels read more than ``OFF_M`` off the scene, either way, is off; fresh off
  windows over ``OFF_AREA`` of the scene flag the frame (judged on sealed set Z).
- Thin lines and dots that never deviate densely: a return read far beyond its pixel's clean range
  (``FAR_ABS``, ``FAR_REL``), which the sensor's own flicker does not do; fresh such returns over ``FAR_AREA``
  of the scene flag the frame (judged on sealed set P), and the repair then takes the scene's depth for
  each of them (sealed set AA), and for such returns in patches where the scene seldom returns (set AB).
- Start-up: no evidence until ``warm`` clean frames are in (``Evidence.ready`` is False).
- Cost: the ring of the last ``frames`` clean frames is re-summarized one stripe of rows (of ``stripes``) per
  added frame, so no frame pays for a full re-sort. 16 stripes (a pixel's statistics at most 16 clean frames
  old) cost a still L515 frame 4.2-4.4 ms where 8 cost 5.1, with the same verdicts on sealed set L
  (docs/research/decisions.md, 2026-11-27).
- Lasting change (a chair moved): a pixel that deviates for ``persist`` frames in a row takes its new value
  as the reference. A person walking past deviates only briefly per pixel, so the median discounts them.
- Moving objects: a deviating pixel that a deviating pixel of the frame before, within ``MOTION_PX``, read
  at about the same depth (or as a dropout, for a dropout) is something that moved, not interference, which
  flickers from frame to frame (``Evidence.fresh`` leaves it out). Interference that stays in place from
  one frame to the next is left out with it: a miss, never a false repair.
- The camera moved, or the scene changed wholesale: when more than ``moved`` of the known scene deviates for
  ``moved_frames`` frames in a row, the reference starts again (no evidence until warm); a frame more than
  ``ELSEWHERE`` of which deviates gets no evidence at all (another view).
"""

from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from d2sr.contract import SceneRepair, crop_around
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import to_metres
from d2sr.labels import CleanStats, Labeller, blur_shares, count_from, stack_stats

__all__ = [
    "EVIDENT",
    "FAR_AREA",
    "MOTION_PX",
    "OFF_AREA",
    "QUIET",
    "SHIFT_AREA",
    "STILL_SHARE",
    "Evidence",
    "SceneReference",
]

#: A frame whose dense evidence is below this matches its scene: the detector's flag on it is a false alarm.
#: Chosen on outside sets A-F and the clean L515 sequences (docs/research/scene-reference.md).
QUIET = 0.0005
#: A frame whose fresh dense evidence reaches this is interfered, whatever the detector says: the lowest of
#: 0.001/0.002/0.003 that keeps the walking person of L515 dev0 within 1% of frames flagged (development
#: figures on sets A-F and the clean L515 sequences: docs/research/scene-reference.md).
EVIDENT = 0.003
#: How far (m, and share of the range) beyond a pixel's clean range a depth must lie to deviate. Tighter
#: than ``d2sr label``'s (2 cm + 1%): a surface read 2-5 cm too near is what the reference is for.
TOL_ABS, TOL_REL = 0.005, 0.005
#: A reference pixel is trusted as a repair when it returned in this share of the clean frames and their
#: depths spread by at most ``TRUST_ABS`` + ``TRUST_REL`` x depth (its own noise, not the model's 10%).
TRUST_RATE, TRUST_ABS, TRUST_REL = 0.9, 0.02, 0.01
#: A window (px) of steady pixels whose mean reads more than ``SHIFT_M`` (m) off the scene deviates where its
#: pixels read that far off the same way, though each may lie within its own tolerance: a CW-ToF camera's
#: light reads a surface 2-5 cm off (set G; bench/shift_probe.py). Half of ``SHIFT_M`` per pixel changed 2.1%
#: of set A's clean pixels (over issue 42's 2%), ``SHIFT_M`` 1.95%. They mark pixels to repair, not frames:
#: as a flag they missed sealed set H's bar (decisions.md, 2026-11-26).
SHIFT_PX, SHIFT_M = 15, 0.01
#: Shifted windows are worked out over pixels that return in this share of the clean frames: many pixels of a
#: real L515 surface flicker more than ``TRUST_RATE`` allows. It lifted development sets G, H, M and U's
#: recall by 0.03-0.10 and sealed set V's from 0.60 to 0.70, with no clean frame flagged more; the clean
#: frames' most fresh shifted area rose to 0.005, half of ``SHIFT_AREA`` (decisions.md, 2026-11-27).
SHIFT_RATE = 0.7
#: A shifted pixel read within this of the scene (the clip ``_shifted`` puts on one pixel's part in a window)
#: is a subtle shift, for ``SceneReference(subtle_shifts=True)``.
SHIFT_CAP = 3 * SHIFT_M
#: The most a surface shifted as a whole reads off for ``SceneReference(offset_fill=True)`` to take its
#: window's offset over the scene's own depth: a CW-ToF camera's light shifts a surface 2-5 cm (issue 42).
#: Beyond it, the shifts of sets A, B and C vary within a window and the scene's median puts back more.
OFFSET_CAP = 0.05
#: A frame whose fresh shifted windows (``Evidence.fresh_shifted``) cover this share of the known scene is
#: interfered: about twice the most any clean development frame reached (0.0043). It lifted sets G and H's
#: recall from 0.35 / 0.20 to 0.85 / 0.83 and sealed set M's from 0.17 to 0.70, with no clean frame flagged
#: more (docs/research/decisions.md, 2026-11-27).
SHIFT_AREA = 0.01
#: A window (``SHIFT_PX``) of the shifted windows' pixels at least half of which read more than ``OFF_M``
#: (m) off the scene's median, either way, is off as a whole: a surface rippled or blotched a few
#: centimetres, whose signed mean a shifted window does not see (set O's blotches, T-V). Fresh such windows
#: over ``OFF_AREA`` of the known scene flag a frame: twice the most any clean development frame reached
#: (0.00049). It lifted sealed set Z's recall on recordings from 0.28 to 0.65, and development sets O, T, U
#: and V's by 0.10-0.18, with no clean frame flagged more (docs/research/decisions.md, 2026-11-27).
OFF_M, OFF_AREA = 0.02, 0.001
#: A return read this far (m, and share of the range) beyond its pixel's clean range, where the scene
#: returns at least ``RANGE_RATE`` of the time, is far off: the sensor's own flicker does not do that (on
#: clean development frames at most 0.0005 of the scene, fresh; interference's thin lines and dots, which
#: never deviate densely, do: sets B, C, F and K).
FAR_ABS, FAR_REL = 0.1, 0.05
#: A frame whose fresh far-off returns (``Evidence.fresh_far``) cover this share of the known scene is
#: interfered: twice the most any clean development frame reached. It lifted K's recall from 0.38 to 0.83
#: and C's from 0.67 to 0.88, and sealed set P's (thin strokes and rings) from 0 to 0.37, with no clean
#: frame flagged more (docs/research/decisions.md, 2026-11-27).
FAR_AREA = 0.001
#: A frame more than this share of whose known scene deviates is taken for another view (the camera moved):
#: the reference says nothing of it. Frames of another L515 view deviate by 0.81-0.89, interference on sets
#: A-G by at most 0.58.
ELSEWHERE = 0.7
#: A pixel's clean range says where its surface is only where it returned in at least this share of the
#: clean frames; a return where it seldom returns is kept as it is (a model moved such clean returns by
#: metres on development set D).
RANGE_RATE = 0.5
#: The sensor counts as still, and its scene's evidence is used, once the ``STILL_Q`` quantile of the shares
#: of the known scene that the last ``STILL_FRAMES`` frames the scene took as clean deviated by is at most
#: ``STILL_SHARE`` (at least ``STILL_MIN`` such frames since the scene last started). Still L515s deviate by
#: a median 0.011 / 0.012 a frame, the hand-held D435 by 0.36; one frame's share cannot tell, since
#: interference lifts it to 0.58, and a median shuts the gate where interfered frames pass as clean (set D
#: lost 0.27 of recall at 0.05). Chosen on development sequences (docs/research/scene_gate.py).
STILL_SHARE, STILL_Q, STILL_FRAMES, STILL_MIN = 0.1, 0.25, 16, 1
#: After a restart because the view changed, the scene rests (judges and keeps nothing) for ``REST`` frames,
#: twice as long after each further such restart before its gate opens, up to ``REST_MAX`` (4 s at 30 fps):
#: a sensor that keeps moving pays for no scene it cannot use (docs/research/decisions.md, 2026-11-27).
REST, REST_MAX = 15, 120
#: How far (px) a moving object's surface can travel between two frames and still explain a deviation.
MOTION_PX = 15
AROUND = 81  # pixels in a 9x9 neighbourhood (_neighbours)
HALF, QUARTER = math.ceil(AROUND / 2), math.ceil(AROUND / 4)  # counts at or above half, a quarter of it
#: How near (m, and share of the range) a deviation must read to one of the frame before to be explained.
MOTION_ABS, MOTION_REL = 0.05, 0.05
#: The statistics the evidence and the repair read, refreshed stripe by stripe (``median`` and ``mean_err``
#: are ``d2sr label``'s, for the paper's method only).
READ = ("rate", "nz_median", "lo", "hi")


@dataclass
class Evidence:
    """A frame judged against the scene reference. ``fresh`` (bool: ``mask`` less what the frame before's
    deviations explain, something that moved) and ``fresh_dense`` (``dense`` of ``fresh``) are worked out
    when first read (``explain``): on most frames ``evident`` needs neither."""

    mask: np.ndarray  # bool: pixels that deviate as interference would (all False when not ready)
    share: float  # of the pixels the reference has seen return
    dense: float  # the same share counting only pixels amid others (half of their 9x9 neighbourhood)
    ready: bool  # the reference had its ``warm`` frames (else the evidence is empty)
    metres: np.ndarray  # the frame judged (float32 metres)
    explain: Callable[[], tuple[np.ndarray, float]] = field(repr=False)  # -> (fresh, fresh_dense)
    still: bool = True  # the sensor held still (``STILL_SHARE``): else the evidence is not to be used
    shifted: float = 0.0  # share of the known scene in shifted windows (``SceneReference._shifted``)
    shift_area: float | None = None  # fresh shifted windows this share of the scene flag it (None: never)
    _fresh: tuple[np.ndarray, float] | None = field(default=None, init=False, repr=False)
    _shift: np.ndarray | None = field(default=None, repr=False)  # bool: the shifted windows' pixels
    _known: int = field(default=1, repr=False)  # pixels the reference has seen return (the shares' base)
    off: float = 0.0  # share of the known scene in off windows (``OFF_M``; with ``SceneReference.off_area``)
    off_area: float | None = None  # fresh off windows over this share of the scene flag it (None: never)
    _off: np.ndarray | None = field(default=None, repr=False)  # bool: the off windows' pixels
    far: float = 0.0  # share of the known scene read far off (``FAR_ABS``, ``FAR_REL``)
    far_area: float | None = None  # fresh far-off returns over this share of the scene flag it (None: never)
    _far: np.ndarray | None = field(default=None, repr=False)  # bool: the returns read far off
    # With ``far_thin``: ``_far``'s fresh share is worked out against the frame before on its own (thin
    # far-off returns need not be among ``mask``'s deviations), as the off windows' always is.
    _far_thin: bool = field(default=False, repr=False)
    _before: np.ndarray | None = field(default=None, repr=False)  # the frame before's deviations

    @property
    def fresh(self) -> np.ndarray:
        return self._explained()[0]

    @property
    def fresh_dense(self) -> float:
        return self._explained()[1]

    @property
    def known(self) -> int:
        """The pixels the reference has seen return: the base of every share here."""
        return self._known

    @property
    def usable(self) -> bool:
        """Evidence a verdict may rest on: the reference is warm and the sensor held still."""
        return self.ready and self.still

    @functools.cached_property
    def fresh_shifted(self) -> float:
        """The share of the known scene in shifted windows that nothing moving explains."""
        if self._shift is None or not self.shifted:
            return 0.0
        return float(np.count_nonzero(self.fresh & self._shift)) / self._known

    @functools.cached_property
    def fresh_off(self) -> float:
        """The share of the known scene in off windows that nothing moving explains."""
        if self._off is None or not self.off:
            return 0.0
        return self._fresh_alone(self._off)

    @functools.cached_property
    def fresh_far(self) -> float:
        """The share of the known scene read far off, not explained by something that moved."""
        if self._far is None or not self.far:
            return 0.0
        return float(np.count_nonzero(self.fresh_far_pixels)) / self._known

    @functools.cached_property
    def fresh_far_pixels(self) -> np.ndarray:
        """bool: the returns read far off that nothing moving explains (``fresh_far``'s pixels)."""
        if self._far is None or not self.far:
            return np.zeros(self.mask.shape, bool)
        if self._far_thin:
            return _unexplained(self.metres, self._far, self._before)
        return self.fresh & self._far

    def _fresh_alone(self, pixels: np.ndarray) -> float:
        """The share of the known scene in ``pixels`` (bool) that nothing moving explains, worked out against
        the frame before on their own, not among ``mask``."""
        return float(np.count_nonzero(_unexplained(self.metres, pixels, self._before))) / self._known

    @property
    def far_evident(self) -> bool:
        """Fresh far-off returns alone cover ``far_area`` of the scene (one of the ways ``evident`` holds)."""
        return self._covers(self.far_area, self.far, lambda: self.fresh_far)

    @property
    def shift_evident(self) -> bool:
        """Fresh shifted windows alone cover ``shift_area`` of the scene (a way ``evident`` holds)."""
        return self._covers(self.shift_area, self.shifted, lambda: self.fresh_shifted)

    def _covers(self, area: float | None, whole: float, fresh: Callable[[], float]) -> bool:
        """Usable, and one kind of evidence covers ``area`` of the scene, wholly and freshly; ``fresh`` is
        worked out only when ``whole`` does (a fresh share is at most its whole one)."""
        return self.usable and area is not None and whole >= area and fresh() >= area

    @property
    def evident(self) -> bool:
        """``fresh_dense`` reaches ``EVIDENT``, or fresh shifted windows cover ``shift_area`` (or off windows
        ``off_area``, or far-off returns ``far_area``): interfered,
        whatever a detector says (only when ``usable``). Each fresh share is at most its whole one, so a
        frame whose whole shares are below the marks is not worked out."""
        if not self.usable:
            return False
        if self.dense >= EVIDENT and self.fresh_dense >= EVIDENT:
            return True
        return (
            self.shift_evident
            or self._covers(self.off_area, self.off, lambda: self.fresh_off)
            or self.far_evident
        )

    def _explained(self) -> tuple[np.ndarray, float]:
        if self._fresh is None:
            self._fresh = self.explain()
        return self._fresh


class SceneReference:
    """Per-pixel scene statistics of one still sensor, from the frames ``add`` is given (those judged clean),
    and each new frame's ``evidence`` against them. Frames are uint16 in the sensor's units."""

    _stats: CleanStats | None  # None until warm
    _labeller: Labeller | None
    _streak: np.ndarray | None  # per pixel, frames in a row it has deviated
    _steady: np.ndarray  # bool: pixels the scene is sure of (``TRUST_RATE``), once warm (``_limits``)
    _shift_px: np.ndarray  # bool: pixels shifted windows are worked out over (``shift_rate``), once warm
    _far_lo: np.ndarray  # with ``far_area``: a return below this is far off, once warm (``_limits``)
    _far_hi: np.ndarray  # and above this
    _returned: np.ndarray  # per row, pixels it has seen return, once warm
    _known: int  # their sum (at least 1)

    def __init__(
        self,
        depth_scale: float,
        frames: int = 16,
        warm: int = 4,
        stripes: int = 16,
        persist: int = 30,
        moved: float = 0.1,
        moved_frames: int = 3,
        tol_abs: float = TOL_ABS,
        tol_rel: float = TOL_REL,
        still_share: float | None = STILL_SHARE,
        rest: int = REST,
        shift_area: float | None = SHIFT_AREA,
        return_rate: float = RANGE_RATE,
        far_area: float | None = FAR_AREA,
        far_thin: bool = True,
        rare_near: bool = True,
        reliable_fill: bool = True,
        subtle_shifts: bool = False,
        shift_rate: float = SHIFT_RATE,
        shift_rate_full: bool = True,
        off_area: float | None = OFF_AREA,
        far_fill: bool = True,
        rare_fill: bool = True,
        offset_fill: bool = True,
    ) -> None:
        """``still_share``: the stillness gate (``STILL_SHARE``); None: the sensor is taken to be still.
        ``rest``: frames the scene rests after a restart because the view changed (``REST``; 0: none).
        ``shift_area``: fresh shifted windows covering this share of the scene flag a frame (``SHIFT_AREA``;
        None: they only mark pixels). ``far_area``: fresh far-off returns (``FAR_ABS``, ``FAR_REL``)
        covering this share of the scene flag a frame (``FAR_AREA``; None: never); ``far_thin``: counted
        over every return (strokes one pixel wide), not only among the density-filtered deviations (sealed
        set Q, docs/research/decisions.md, 2026-11-27). ``rare_near``: the repair keeps a return where the
        scene seldom returns (``RANGE_RATE``) only within ``FAR_ABS`` + ``FAR_REL`` of the depth it returned
        at (or where it never returned), not any such return (sealed set R, decisions.md, 2026-11-27).
        ``reliable_fill``: the repair also takes the scene's depth for a fresh deviation amid a quarter of
        fresh neighbours (``QUARTER``, not ``HALF``) where the scene nearly always returns (``TRUST_RATE``):
        on sealed set S and every development set it put more back and made each view better (S: RMSE
        -17.3% -> -22.4%), for 0.02-0.05 points more clean pixels changed (decisions.md, 2026-11-27).
        ``subtle_shifts`` (off, experimental): a shifted pixel read within ``SHIFT_CAP`` of the scene is
        explained by the frame before only where one of its deviations nearby read within ``SHIFT_M`` of its
        depth, not the ``MOTION_ABS`` + ``MOTION_REL`` a moving object needs. It found one or two more frames
        on development sets G, H and M but none on sealed set U (decisions.md, 2026-11-27).
        ``shift_rate``: shifted windows are worked out over the pixels that returned in at least this share
        of the clean frames [``SHIFT_RATE``; ``TRUST_RATE``, the steady ones, before sealed set V];
        ``shift_rate_full``: only once the ring holds ``frames`` clean frames, the steady ones before (sealed
        set W, decisions.md, 2026-11-27: on development set D's live start it kept 2 clean frames unflagged).
        ``off_area``: fresh off windows (``OFF_M``) covering this share of the scene flag a frame
        (``OFF_AREA``, since sealed set Z; None: never). They only flag: the repair does not read them.
        ``far_fill``: where a frame's fresh far-off returns alone cover ``far_area`` of the scene
        (``Evidence.far_evident``: more than the sensor's own flying returns ever do), the repair takes the
        scene's depth for each of them, not only for deviations in patches: on sealed set AA it put back
        more (51% -> 58% of the pixels moved by more than 2 cm, as a recording) and made no frame worse
        (decisions.md, 2026-11-27).
        ``rare_fill``: in such a frame, also a fresh return where the scene returned in under ``RANGE_RATE``
        of its clean frames but at least once, read beyond ``FAR_ABS`` + ``FAR_REL`` of the depth it returned
        at, amid at least a quarter (``QUARTER``) of such returns and fresh far-off ones in its 9x9
        neighbourhood, takes the scene's depth: the sensor's own returns there can lie metres off too, but
        alone or a few together. On sealed set AB it put back more (45% -> 49% of the pixels moved by more
        than 2 cm, as a recording) and made no frame worse (decisions.md, 2026-11-27).
        ``offset_fill``: in a frame whose fresh shifted windows flag it
        (``Evidence.shift_evident``), a return amid a surface shifted as a whole (``SHIFT_PX`` windows whose
        fresh shifted pixels are a quarter of the window and half of its returns) that reads off the same
        way, by at least half their mean offset, takes its own depth less that offset: where the scene would
        keep it, and where the scene's fill would write its median if their offsets agree (spread at most
        ``SHIFT_M``) and the offset is at most ``OFFSET_CAP``. Each pixel keeps its own reading, so noisy
        pixels come back within their noise, not at the median's distance from it. On sealed set AC
        (CW-ToF shifts, no dropouts) it put back more (50% -> 60% of the pixels moved by more than 2 cm, as a
        recording) and made no frame worse (decisions.md, 2026-11-27).
        ``return_rate``: a return the scene repairs needs to have returned in this share of the clean frames,
        at depths that agree (``TRUST_ABS``, ``TRUST_REL``) [``RANGE_RATE``: on sealed set O and every
        development set it put more back and made no frame worse than ``TRUST_RATE``,
        docs/research/decisions.md, 2026-11-27]."""
        if not depth_scale > 0:
            raise ConfigError(f"depth_scale must be positive, got {depth_scale}")
        if not 3 <= warm <= frames:
            raise ConfigError(f"need 3 <= warm <= frames, got warm={warm}, frames={frames}")
        if stripes < 1 or persist < 1 or moved_frames < 1 or not 0 < moved <= 1:
            raise ConfigError("stripes, persist and moved_frames must be >= 1 and moved in (0, 1]")
        if still_share is not None and not 0 < still_share <= 1:
            raise ConfigError(f"still_share must be in (0, 1], got {still_share}")
        if rest < 0:
            raise ConfigError(f"rest must be >= 0, got {rest}")
        if shift_area is not None and not 0 < shift_area <= 1:
            raise ConfigError(f"shift_area must be in (0, 1], got {shift_area}")
        if not 0 < shift_rate <= 1:
            raise ConfigError(f"shift_rate must be in (0, 1], got {shift_rate}")
        if not 0 < return_rate <= 1:
            raise ConfigError(f"return_rate must be in (0, 1], got {return_rate}")
        if far_area is not None and not 0 < far_area <= 1:
            raise ConfigError(f"far_area must be in (0, 1], got {far_area}")
        if off_area is not None and not 0 < off_area <= 1:
            raise ConfigError(f"off_area must be in (0, 1], got {off_area}")
        self.off_area = off_area
        self.still_share, self.rest, self.shift_area = still_share, rest, shift_area
        self.return_rate, self.far_area, self.far_thin, self.rare_near = (
            return_rate,
            far_area,
            far_thin,
            rare_near,
        )
        self.reliable_fill, self.subtle_shifts, self.shift_rate = reliable_fill, subtle_shifts, shift_rate
        self.shift_rate_full, self.far_fill, self.rare_fill = shift_rate_full, far_fill, rare_fill
        self.offset_fill = offset_fill
        self._naps = 0  # restarts because the view changed since the gate was last open
        self.scale = float(depth_scale)
        self.size, self.warm, self.stripes = frames, warm, stripes
        self.persist, self.moved, self.moved_frames = persist, moved, moved_frames
        self.tol = (tol_abs, tol_rel)
        self._ring: np.ndarray | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the scene (the next ``warm`` clean frames build it again)."""
        self.count = 0  # clean frames in the ring (at most ``frames``)
        self._next = 0  # ring slot the next clean frame goes to
        self._stripe = 0  # stripe of rows the next ``add`` re-summarizes
        self._stats, self._labeller, self._streak, self._moving = None, None, None, 0
        self._before: np.ndarray | None = None  # the frame before's deviating depths (m; -1: a dropout)
        self._judged: float | None = None  # the share the last frame judged deviated by (None: not judged)
        self._resting = 0  # frames the scene still rests (``REST``)
        self._skip = False  # the last frame judged came while resting: ``add`` keeps nothing
        self._clean: deque[float] = deque(maxlen=STILL_FRAMES)  # those of the frames then taken as clean

    @property
    def still(self) -> bool:
        """The sensor held still, as its scene sees it (``STILL_SHARE``): its evidence may be used."""
        if self.still_share is None:
            return True
        return len(self._clean) >= STILL_MIN and _quantile(self._clean, STILL_Q) <= self.still_share

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
        if self._ring is None:
            self._ring = np.zeros((self.size, *frame.shape), np.uint16)
        self._ring[self._next] = frame
        self._next = (self._next + 1) % self.size
        self.count = min(self.count + 1, self.size)
        if self.count < self.warm:
            return
        h = frame.shape[0]
        if self._stats is None:  # just warm: every stripe at once
            self._stats = _stats(self._ring[: self.count], self.scale)
            self._labeller = Labeller(self._stats, tol_abs=self.tol[0], tol_rel=self.tol[1])
            self._steady = np.zeros(frame.shape, bool)
            # At TRUST_RATE the shifted windows' pixels are the steady ones: the same array, kept once.
            self._shift_px = self._steady if self.shift_rate == TRUST_RATE else np.zeros(frame.shape, bool)
            self._far_lo = np.zeros(frame.shape, np.float32)
            self._far_hi = np.zeros(frame.shape, np.float32)
            self._returned = np.zeros(frame.shape[0], np.int64)
            self._limits()
            self._streak = np.zeros(frame.shape, np.uint16)
            return
        rows = -(-h // self.stripes)
        r0 = self._stripe * rows
        r1 = min(h, r0 + rows)
        fresh = stack_stats(self._ring[: self.count, r0:r1], READ)
        for name, v in _metres(fresh, self.scale).items():
            getattr(self._stats, name)[r0:r1] = v
        self._limits(slice(r0, r1))
        self._stripe = (self._stripe + 1) % self.stripes

    def _limits(self, rows: slice = slice(None)) -> None:
        """The per-pixel limits the evidence compares a frame with, worked out again where the statistics
        changed: the labeller's, and the steady pixels of ``_shifted``."""
        s, labeller = self._stats, self._labeller
        assert s is not None and labeller is not None
        labeller.refresh(rows)
        self._steady[rows] = (s.rate[rows] >= TRUST_RATE) & (s.nz_median[rows] > 0)
        if self._shift_px is not self._steady:
            self._shift_px[rows] = (s.rate[rows] >= self.shift_rate) & (s.nz_median[rows] > 0)
        self._returned[rows] = np.count_nonzero(s.rate[rows] > 0, axis=1)  # per row: pixels seen returning
        # Where a return is far off (``FAR_ABS``, ``FAR_REL``), only where the scene returns at least
        # ``RANGE_RATE`` of the time (+-inf elsewhere).
        if self.far_area is not None:
            tol = FAR_ABS + FAR_REL * s.nz_median[rows]
            often = s.rate[rows] >= RANGE_RATE
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
            return _none(frame.shape)
        if self._labeller is None or self._stats is None or self._streak is None:
            return _none(frame.shape)
        metres = to_metres(frame, self.scale) if metres is None else metres
        deviates = self._labeller.mask(metres)
        known = self._known
        share = float(np.count_nonzero(deviates)) / known
        # Another view (beyond ELSEWHERE) counts toward a restart too, and gets no evidence.
        self._moving = self._moving + 1 if share > min(self.moved, ELSEWHERE) else 0
        if self._moving >= self.moved_frames:
            self.reset()
            if self.rest:  # the view changed: rest, longer each time until the gate opens again
                self._resting = min(self.rest << min(self._naps, 16), max(REST_MAX, self.rest))
                self._naps += 1
                self._skip = True  # this frame, of the view that moved, is not kept either
            return _none(frame.shape)
        if share > ELSEWHERE:
            return _none(frame.shape)
        still = self.still  # as the frames before this one showed
        if still:
            self._naps = 0
        self._judged = share
        shift, off_px = self._shifted(metres)
        mask = deviates | shift
        near = _neighbours(deviates)
        dense = float(np.count_nonzero(near >= HALF)) / known  # flicker is scattered, interference in patches
        before = self._before

        stats = self._stats

        def explain() -> tuple[np.ndarray, float]:
            subtle = None
            if self.subtle_shifts and shift.any():
                subtle = shift & (np.abs(metres - stats.nz_median) <= SHIFT_CAP)
            fresh = _unexplained(metres, mask, before, subtle)
            if fresh is mask:  # nothing explained: its dense share is the frame's
                return mask, dense
            return fresh, _dense(fresh & deviates, known)

        # What explains the next frame's deviations: this one's, in patches (a moved object), not flicker;
        # their depths, -1 a dropout, written where they are (patches are few).
        at = np.flatnonzero(mask & ((_neighbours(mask) if shift.any() else near) >= QUARTER))
        explains = np.zeros_like(metres)
        depth = metres.ravel()[at]
        explains.ravel()[at] = np.where(depth > 0, depth, np.float32(-1))
        self._before = explains
        self._streak += 1  # in place: at most ``persist`` (``_take`` clears it there)
        self._streak *= mask
        lasting = self._streak >= self.persist
        if lasting.any():
            self._take(frame, lasting)
        shifted = float(np.count_nonzero(shift)) / known if self.shift_area is not None else 0.0
        off = float(np.count_nonzero(off_px)) / known if off_px is not None else 0.0
        far_off = None
        if self.far_area is not None:  # over every return, or among the density-filtered deviations
            far_off = (metres > 0) & ((metres < self._far_lo) | (metres > self._far_hi))
            if not self.far_thin:
                far_off &= deviates
        far = float(np.count_nonzero(far_off)) / known if far_off is not None else 0.0
        return Evidence(
            mask,
            share,
            dense,
            True,
            metres,
            explain,
            still,
            shifted=shifted,
            shift_area=self.shift_area,
            _shift=shift,
            off=off,
            off_area=self.off_area,
            _off=off_px,
            _known=known,
            far=far,
            far_area=self.far_area,
            _far=far_off,
            _far_thin=self.far_thin,
            _before=before,
        )

    def _shifted(self, metres: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Pixels returning in ``shift_rate`` of the clean frames (``SHIFT_RATE``) in a ``SHIFT_PX`` window of
        them whose mean difference from the scene is beyond ``SHIFT_M``, themselves that far off the same way:
        a surface read a few centimetres off, within each pixel's tolerance but not the window's. With
        ``off_area``, also the off windows' pixels (``OFF_M``; else None)."""
        s = self._stats
        assert s is not None
        px = self._steady if self.shift_rate_full and self.count < self.size else self._shift_px
        steady = (metres > 0) & px
        diff = np.subtract(metres, s.nz_median, dtype=np.float32)
        diff *= steady  # 0 (or -0, the same to every use below) off the steady returns
        clipped = np.clip(diff, -SHIFT_CAP, SHIFT_CAP)  # one far-off pixel cannot shift a window
        count = cv2.boxFilter(steady.view(np.uint8), -1, (SHIFT_PX, SHIFT_PX), normalize=False)
        total = cv2.blur(clipped, (SHIFT_PX, SHIFT_PX))
        # Only a steady pixel that reads that far off itself, amid at least half steady ones, can be shifted:
        # the window's mean is worked out there alone (its share as cv2.blur gives it, from the count).
        amid = count >= count_from(0.5, SHIFT_PX)
        size = np.abs(diff)  # 0 off the steady returns
        own = steady & (size > SHIFT_M) & amid
        at = np.flatnonzero(own)
        n = blur_shares(SHIFT_PX)[count.ravel()[at]]
        mean = total.ravel()[at] / np.maximum(n, np.float32(1e-6))
        out = np.zeros(metres.shape, bool)
        # The window reads off, and the pixel itself as far and the same way (not merely next to it).
        out.ravel()[at] = (np.abs(mean) > SHIFT_M) & (diff.ravel()[at] * mean > 0)
        if self.off_area is None or self.count < self.size:
            return out, None
        # Off windows, against the median of a full ring only (a young scene's medians wander by centimetres):
        # at least half the window's steady pixels read beyond OFF_M either way, the pixel itself too (counted
        # in integers: a float share costs more than the window sums).
        far = size > OFF_M
        n_far = cv2.boxFilter(far.view(np.uint8), -1, (SHIFT_PX, SHIFT_PX), normalize=False)
        off = far & amid & (n_far >= ((count + 1) >> 1))
        return out, off

    def repair(self, ev: Evidence) -> SceneRepair:
        """What the scene knows of ``ev``'s frame. Where the reference is trusted (``TRUST_RATE``,
        ``TRUST_ABS``, ``TRUST_REL``), its own depth for the fresh deviations in patches (``fill``). Outside
        the deviations in patches, which are the model's to repair, a returning pixel that reads within the
        range the scene has seen it at, or where the scene seldom returns (``RANGE_RATE``), is left as it is
        (``keep``): the scene finds no interference there, and a model's guess could only do harm. With
        ``far_fill``, also its depth for each fresh far-off return of a frame they flag (with ``rare_fill``,
        for such returns in patches where it seldom returns too). Nothing when not usable."""
        s = self._stats
        shape = ev.mask.shape
        if s is None or not ev.usable:
            none = np.zeros(shape, bool)
            return SceneRepair(none, np.zeros(shape, np.float32), none)
        m = ev.metres
        # A return where the scene's clean depths agree is trusted from ``return_rate``: it did return, and
        # the scene says where; a dropout only where the scene nearly always returns (``TRUST_RATE``).
        rate = np.where(m > 0, np.float32(self.return_rate), np.float32(TRUST_RATE))
        trusted = (s.rate >= rate) & (s.hi - s.lo <= TRUST_ABS + TRUST_REL * s.nz_median)
        trusted &= s.nz_median > 0
        near = _neighbours(ev.fresh)
        patches = near >= HALF
        if self.reliable_fill:  # where the scene nearly always returns (steady), sparser patches too
            patches |= (near >= QUARTER) & self._steady
        where = ev.fresh & patches & trusted
        far_frame = (self.far_fill or self.rare_fill) and ev.far_evident
        if far_frame and self.far_fill:
            # Each return read far beyond where the scene returns half the time or more (so it has a depth
            # there), in a frame with more such returns than the sensor's own flicker makes: interference.
            where |= ev.fresh_far_pixels
        tol = self.tol[0] + self.tol[1] * s.nz_median
        within = (m >= s.lo - tol) & (m <= s.hi + tol)
        seldom = s.rate < RANGE_RATE
        far_from_seen = np.abs(m - s.nz_median) > FAR_ABS + FAR_REL * s.nz_median
        if self.rare_near:  # where it seldom returns, only a return near the depth it did return at
            seldom &= (s.rate == 0) | ~far_from_seen
        if far_frame and self.rare_fill:
            # Where it seldom returns but did, a fresh return far from that depth, amid a quarter of such
            # returns and far-off ones: the sensor's own stray returns there come alone or a few together.
            rare = (m > 0) & (s.rate > 0) & (s.rate < RANGE_RATE) & far_from_seen
            rare = _unexplained(m, rare, ev._before)
            rare &= _neighbours(rare | ev.fresh_far_pixels) >= QUARTER
            where |= rare
        keep = (m > 0) & ~ev.mask & (seldom | within)
        depth = np.where(where, s.nz_median, 0).astype(np.float32)
        if self.offset_fill and ev.shift_evident:
            at, by = _offsets(ev, s, where)
            where, keep = where | at, keep & ~at
            depth[at] = m[at] - by[at]
        return SceneRepair(where, depth, keep)

    def _take(self, frame: np.ndarray, where: np.ndarray) -> None:
        """Pixels that have deviated for ``persist`` frames: their new value is the scene now."""
        assert self._ring is not None and self._stats is not None and self._streak is not None
        self._ring[:, where] = frame[where]
        v = frame[where].astype(np.float32) / np.float32(self.scale)
        s = self._stats
        s.median[where] = v
        s.nz_median[where] = s.lo[where] = s.hi[where] = v
        s.rate[where] = (v > 0).astype(np.float32)
        s.mean_err[where] = 0
        self._streak[where] = 0
        self._limits()


def _offsets(ev: Evidence, s: CleanStats, filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bool: returns of a surface shifted as a whole, float32: their window's mean offset in metres) for
    ``SceneReference(offset_fill=True)``. A window's mean over a hundred-odd pixels is known to a few
    millimetres where each pixel's own noise spans centimetres. ``filled``: where the scene's fill writes
    its median; there only an agreeing offset within ``OFFSET_CAP`` replaces it."""
    m = ev.metres
    has = (m > 0) & (s.rate >= RANGE_RATE) & (s.nz_median > 0)
    diff = np.subtract(m, s.nz_median, dtype=np.float32)
    diff *= has  # products, not np.where: a third of the time on scattered masks
    assert ev._shift is not None  # a shift-evident frame has shifted windows
    shifted = ev.fresh & ev._shift
    k = (SHIFT_PX, SHIFT_PX)
    n = cv2.boxFilter(shifted.view(np.uint8), cv2.CV_32F, k, normalize=False)  # at most 225
    within = cv2.boxFilter(has.view(np.uint8), cv2.CV_32F, k, normalize=False)
    part = diff * shifted
    count = np.maximum(n, np.float32(1))
    mean = cv2.boxFilter(part, -1, k, normalize=False) / count
    spread = cv2.boxFilter(part * part, -1, k, normalize=False) / count - mean * mean
    whole = (n >= np.float32(SHIFT_PX * SHIFT_PX / 4)) & (2 * n >= within)
    alike = (diff * mean > 0) & (np.abs(diff) >= np.float32(0.5) * np.abs(mean))
    agree = (np.abs(mean) <= OFFSET_CAP) & (spread <= np.float32(SHIFT_M * SHIFT_M))
    return has & whole & alike & (~filled | agree), mean


def _quantile(values: deque[float], q: float) -> float:
    """``np.quantile(values, q)`` (its linear method, the same float64 arithmetic) of a few values, without
    numpy's overhead (a tenth of a millisecond a frame)."""
    v = sorted(values)
    at = q * (len(v) - 1)
    i = min(math.floor(at), len(v) - 1)
    a, b, t = v[i], v[min(i + 1, len(v) - 1)], at - i
    return b - (b - a) * (1 - t) if t >= 0.5 else a + (b - a) * t


def _none(shape: tuple[int, ...]) -> Evidence:
    empty = np.zeros(shape, bool)
    return Evidence(empty, 0.0, 0.0, False, np.zeros(shape, np.float32), lambda: (empty, 0.0))


def _neighbours(mask: np.ndarray) -> np.ndarray:
    """How many of each pixel's 9x9 neighbourhood (``AROUND``) lie in the bool ``mask``, uint8: a sensor's own
    flicker leaves scattered pixels, interference and moved objects come in patches. Counted in integers
    (a tenth of a float blur's time); ``HALF`` and ``QUARTER`` are the shares the callers ask for."""
    return cv2.boxFilter(mask.view(np.uint8), -1, (9, 9), normalize=False)


def _dense(mask: np.ndarray, known: int) -> float:
    """The share of ``known`` pixels amid others in ``mask`` (half of their 9x9 neighbourhood)."""
    return float(np.count_nonzero(_neighbours(mask) >= HALF)) / known


def _unexplained(
    metres: np.ndarray, mask: np.ndarray, before: np.ndarray | None, subtle: np.ndarray | None = None
) -> np.ndarray:
    """The pixels of ``mask`` nothing that moved explains (``_explained``): none on the first frame judged
    against a new reference (``before`` None: no motion to tell by); ``mask`` itself where nothing deviated
    a frame before."""
    if before is None:
        return np.zeros_like(mask)
    if mask.any() and before.any():
        return mask & ~_explained(metres, mask, before, subtle)
    return mask


def _explained(
    metres: np.ndarray, mask: np.ndarray, before: np.ndarray, subtle: np.ndarray | None = None
) -> np.ndarray:
    """Deviating pixels that a deviation of the frame before (``before``: its depths, -1 a dropout, 0 none)
    within ``MOTION_PX`` read at about the same depth: a moved object's surface. ``subtle`` (bool): pixels
    held to ``SHIFT_M`` instead of ``MOTION_ABS`` + ``MOTION_REL`` (``SceneReference.subtle_shifts``)."""
    out = np.zeros(mask.shape, bool)
    # Nothing further than MOTION_PX from the frame before's deviations can be explained: the cost follows
    # them (erode and dilate ignore what lies beyond a crop's edge).
    crop = crop_around(before != 0, MOTION_PX)
    if crop is None:
        return out
    rs, cs = crop
    b, m = before[rs, cs], metres[rs, cs]
    k = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * MOTION_PX + 1, 2 * MOTION_PX + 1))
    lo = cv2.erode(np.where(b > 0, b, np.float32(np.inf)), k)
    hi = cv2.dilate(b, k)
    tol = MOTION_ABS + MOTION_REL * m
    if subtle is not None:
        tol = np.where(subtle[rs, cs], np.float32(SHIFT_M), tol)
    near = (m > 0) & (m >= lo - tol) & (m <= hi + tol)
    dropped = (m == 0) & (cv2.erode(np.where(b < 0, 0, 1).astype(np.uint8), k) == 0)
    out[rs, cs] = mask[rs, cs] & (near | dropped)
    return out


def _metres(part: dict[str, np.ndarray], scale: float) -> dict[str, np.ndarray]:
    """``stack_stats``' depths in metres (``rate`` is a share)."""
    return {k: v if k == "rate" else v / np.float32(scale) for k, v in part.items()}


def _stats(ring: np.ndarray, scale: float) -> CleanStats:
    return CleanStats(frames=ring.shape[0], **_metres(stack_stats(ring), scale))
