"""One sensor's loop: frame -> detect -> buffer the period's flags -> controller -> trigger; repair flagged
frames -> sink. Torch-free: it runs on any ``Backend`` (onnxruntime on the edge).

A source yields ``Capture``s and ``PeriodEnd`` marks. Triggered sources (a simulated room, a live sensor with
a trigger line) give each frame its slot in the period, so a missing frame counts as clean in the
controller's window, as in the timing world. Open-loop sources (recordings) give no slots: every
``active_frames`` frames make a period, and the controller's offsets are only logged.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from d2sr.contract.catalog import THRESHOLD, padded
from d2sr.contract.repair import LINES_UP, REFRESH_FRAMES, agreement, repair_frame
from d2sr.desync import Controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Frame, check_depth, to_metres
from d2sr.runtime.backends import Backend
from d2sr.runtime.settings import PRIME_FRAMES, RunSettings
from d2sr.scene import Evidence, SceneReference, SceneRepair
from d2sr.scene.stored import StoredScene

__all__ = [
    "REASONS",
    "Capture",
    "Decision",
    "PeriodEnd",
    "Result",
    "SensorLoop",
    "Sink",
    "Trigger",
]


@dataclass
class Capture:
    """A frame as the sensor delivered it (``scale`` units per metre), where it sits in the period, and
    its ground truth when the source knows it (simulation)."""

    frame: Frame
    scale: float
    slot: int | None = None  # slot in its period (triggered sources only)
    clean: np.ndarray | None = None
    mask: np.ndarray | None = None
    interfered: bool | None = None
    counted: bool = True  # False: a frame that arrived after its period closed (repaired, not counted)

    @property
    def name(self) -> str:
        return self.frame.name


@dataclass
class PeriodEnd:
    """The observation period is over (triggered sources: at its last slot, frame or not)."""

    period: int


@dataclass
class Result:
    capture: Capture
    score: float  # the detector's; below the threshold, possibly the frame's score alone (contract.gate)
    flagged: bool
    depth: np.ndarray  # what the sink gets: repaired where flagged, else the input (same units)
    mask: np.ndarray  # bool, the repaired pixels
    period: int
    offset: int  # the window offset the sensor ran this frame's period with
    seconds: float = 0.0  # processing time of detect + repair
    # The sensor's scene weighed the verdict (True), or was judged but still being built or the sensor
    # moved (False: the detector decided alone); None: no scene was judged.
    scene: bool | None = None
    reason: str = ""  # why the verdict (``REASONS``)


@dataclass
class Decision:
    """A frame as ``SensorLoop.decide`` left it for ``SensorLoop.finish``."""

    capture: Capture
    metres: np.ndarray  # (1, H', W') padded
    score: float
    flagged: bool
    repair: bool
    previous: np.ndarray | None  # the last clean frame a temporal recovery model sees (metres, padded)
    period: int
    offset: int
    started: float  # perf_counter at decide
    # What the scene knows of the frame (``RunSettings.repairs_scene``), worked out by ``finish``.
    scene: Callable[[], SceneRepair] | None = None
    scene_used: bool | None = None  # ``Result.scene``
    reason: str = ""  # ``Result.reason``


class Trigger(Protocol):
    """Starts the sensor's window at ``offset`` from ``period`` on (hardware line, simulated world)."""

    def set_offset(self, period: int, offset: int) -> None: ...


class Sink(Protocol):
    def write(self, result: Result) -> None: ...


def _detector_alone() -> RunSettings:
    return RunSettings(scene=False)


@dataclass
class SensorLoop:
    """The three stages on one sensor, as ``settings`` say: which frames are repaired (``repair``: the
    flagged ones, the paper's; all, the worst case for speed; none, detection and timing only), the
    detector's threshold, and whether a still sensor's frames are also judged against its own scene
    (``scene``: a flag on a frame in which nothing deviates from the scene is a false alarm and is dropped;
    a frame with fresh deviations in patches is interfered, flagged or not) and repaired from it where it is
    trusted (``repairs_scene``). [The detector alone, as the paper's evaluations measure it.]"""

    backend: Backend
    controller: Controller
    trigger: Trigger | None = None
    sink: Sink | None = None
    settings: RunSettings = field(default_factory=_detector_alone)
    # False: no detector runs (score NaN, never flagged). Only with repair="all" and a single-frame
    # recovery model, where no verdict is used: a temporal one needs to know which frames were clean.
    detect: bool = True
    # False (recover --repair all with a temporal model): the detector runs only where its verdict can change
    # the last clean frame (``REFRESH_FRAMES``); the other frames are repaired unjudged (score NaN).
    judge_every: bool = True
    # True (d2sr detect's scores, for a user's own threshold): every frame scored exactly. False: a frame
    # clear on its own is not weighed against the one before it; its score is then its score alone, below
    # the threshold either way (contract.gate), for half the detector's work on a clean frame.
    exact_scores: bool = False
    period: int = 0
    _reference: SceneReference | None = None
    _stored: StoredScene | None = None  # the stored scene, read once
    _flags: dict[int, bool] = field(default_factory=dict)
    _count: int = 0  # frames seen this period
    _slotted: bool = False  # the source gives slots (triggered) rather than frame order (open loop)
    _last_clean: np.ndarray | None = None  # metres, padded: what a temporal recovery model also sees
    _last: tuple[tuple[int, ...], np.ndarray] | None = None  # the previous frame's size and metres (padded)
    _cut: float = THRESHOLD  # the threshold in use
    _unjudged: int = 0  # frames since the detector last ran
    _mode: str = "flagged"  # the repair in use (none while priming)

    @property
    def offset(self) -> int:
        return self.controller.offset

    def __post_init__(self) -> None:
        if not isinstance(self.settings, RunSettings):
            raise ConfigError(f"settings must be RunSettings, got {type(self.settings).__name__}")
        self._mode = self.settings.repair
        if not self.detect and (self._mode != "all" or getattr(self.backend, "frames", 1) > 1):
            raise ConfigError("detect=False needs repair='all' and a single-frame recovery model")
        if not self.judge_every and (self._mode != "all" or getattr(self.backend, "frames", 1) == 1):
            raise ConfigError("judge_every=False needs repair='all' and a temporal recovery model")
        if self.trigger is not None:
            self.trigger.set_offset(0, self.controller.offset)
        own = float(getattr(self.backend, "threshold", THRESHOLD))
        self._cut = self.settings.threshold if self.settings.threshold is not None else own

    def step(self, item: Capture | PeriodEnd) -> Result | None:
        if isinstance(item, PeriodEnd):
            self.end_period()
            return None
        return self.process(item)

    def process(self, cap: Capture) -> Result:
        return self.finish(self.decide(cap))

    def decide(self, cap: Capture) -> Decision:
        """The part of ``process`` that depends on earlier frames, in frame order: the detector's verdict
        (it weighs the previous frame), what the recovery model will see as the last clean frame, and the
        controller's window. ``finish`` then repairs; it depends on no other frame, so several can run at
        once (``d2sr recover``)."""
        raw = cap.frame.depth
        check_depth(raw, cap.name)  # uint16 in the sensor's units, or float32 metres (scale 1)
        if raw.dtype == np.float32 and cap.scale != 1:
            raise InputError(f"{cap.name}: float32 depth is metres; its scale must be 1, got {cap.scale:g}")
        t = time.perf_counter()
        metres = padded(to_metres(raw, cap.scale)[None])
        last = self._last_clean
        previous = last if last is not None and last.shape == metres.shape else None
        judge = self.detect and (
            self.judge_every
            or previous is None
            or self._unjudged + 1 >= REFRESH_FRAMES
            or agreement(metres, previous) < LINES_UP
        )
        self._unjudged = 0 if judge else self._unjudged + 1
        # A temporal detector also weighs the previous frame as delivered, flagged or not.
        before = self._last[1] if self._last is not None and self._last[0] == raw.shape else None
        cut = None if self.exact_scores else self._cut
        scene = self.settings.scene
        units, ev = self._scene_evidence(raw, cap.scale, metres) if scene and judge else (None, None)
        if ev is not None and _decides(ev) and not self.exact_scores:
            # The scene's verdict stands whatever the detector would say: it is not run (score NaN).
            score, flagged = float("nan"), ev.evident
        else:
            score = float(self.backend.scores(metres, before, cut)[0]) if judge else float("nan")
            flagged = score >= self._cut  # False for NaN
        detector = score >= self._cut  # False for NaN
        if ev is not None and units is not None:
            flagged = self._weigh(units, flagged, ev)
        fix = self._mode == "all" or (flagged and self._mode == "flagged")
        known = None
        if ev is not None and self._reference is not None and self.settings.repairs_scene and fix:
            known = self._reference.repair_later(ev)  # in finish: off the frames' order
        used = ev.usable if ev is not None else None
        d = Decision(
            cap, metres, score, flagged, fix, previous, self.period, self.controller.offset, t, known, used,
            _reason(detector, flagged, ev),
        )  # fmt: skip
        self._remember(raw, metres, judge and not flagged)
        if cap.counted:
            self._buffer(flagged, cap.slot)
        return d

    def prime(self, captures: Sequence[Capture]) -> None:
        """Let the still sensor's scene learn from a recording's frames ahead (with ``scene``), so that its
        first frames are judged against a scene too, not by the detector alone as a live sensor's are. They
        are judged as ``decide`` judges them, from the last to the second, so the scene ends where the
        recording starts; the first is left out, as it would explain its own deviations. Nothing else
        changes: no result, no flag for the controller, no frame the models remember. A scene that is not
        settled at the end (``SceneReference.settled``: the sensor moved) is dropped, since priming a moving
        camera's scene flags its clean frames."""
        if not self.settings.scene or len(captures) < 2:
            return
        kept = (self._mode, self._last, self._last_clean, self._unjudged)
        self._mode = "none"
        try:
            for cap in reversed(captures[1:]):
                self.decide(replace(cap, counted=False))
        finally:
            self._mode, self._last, self._last_clean, self._unjudged = kept
        if self._reference is not None and not self._reference.settled:
            self._reference = None  # the sensor moved over the frames ahead: start cold, as a live one does

    def primed(self, captures: Iterable[Capture], frames: int = PRIME_FRAMES) -> Iterator[Capture]:
        """``captures`` as they come, once the first ``frames`` of them have primed the scene (``prime``;
        0: none, the loop starts cold as a live sensor's does)."""
        if frames < 0:
            raise ConfigError(f"frames to prime the scene must be >= 0, got {frames}")
        return self._primed(iter(captures), frames if self.settings.scene else 0)

    def _primed(self, captures: Iterator[Capture], frames: int) -> Iterator[Capture]:
        ahead = list(itertools.islice(captures, frames))
        self.prime(ahead)
        yield from ahead
        yield from captures

    def finish(self, d: Decision) -> Result:
        """Repair a decided frame (when it is to be repaired) and hand the result to the sink."""
        raw = d.capture.frame.depth
        h, w = raw.shape
        depth, mask = raw, np.zeros(raw.shape, bool)
        if d.repair:
            pred, m = self.backend.recover(d.metres, d.previous)
            known = d.scene() if d.scene is not None else None
            metres = d.metres[0, :h, :w]  # the frame as the model saw it: not converted again
            depth, mask = repair_frame(raw, pred[0, :h, :w], m[0, :h, :w], d.capture.scale, known, metres)
        seconds = time.perf_counter() - d.started
        res = Result(
            d.capture, d.score, d.flagged, depth, mask, d.period, d.offset, seconds, d.scene_used, d.reason
        )
        if self.sink is not None:
            self.sink.write(res)
        return res

    def replay(self, flagged: bool, slot: int | None = None, cap: Capture | None = None) -> None:
        """Feed a flag decided earlier (a resumed run) without running the models; with the frame ``cap``,
        the models' memory of earlier frames is restored too, so a resumed run decides as the first did."""
        if cap is not None:
            raw = cap.frame.depth
            metres = padded(to_metres(raw, cap.scale)[None])
            self._remember(raw, metres, not flagged)
            if self.settings.scene:  # the reference learns as it did the first time (the flag is the same)
                units, ev = self._scene_evidence(raw, cap.scale, metres)
                self._weigh(units, flagged, ev)
        self._buffer(flagged, slot)

    def _scene_evidence(
        self, raw: np.ndarray, scale: float, metres: np.ndarray
    ) -> tuple[np.ndarray, Evidence]:
        """(the frame as the scene reference takes it, ``_in_units``; its evidence against the still sensor's
        scene, a new reference for a new scale or size). ``metres``: the frame as the models take it
        (padded); a uint16 frame's are the reference's too, so it does not convert the frame again."""
        units, scale = _in_units(raw, scale)
        ref = self._reference
        if ref is None or ref.scale != scale or ref.shape not in (None, units.shape):
            ref = self._reference = self._new_reference(scale, units.shape)
        own = metres[0, : raw.shape[0], : raw.shape[1]] if raw.dtype == np.uint16 else None
        return units, ref.evidence(units, own)

    def _new_reference(self, scale: float, shape: tuple[int, ...]) -> SceneReference:
        """The sensor's scene: from its stored scene (``RunSettings.scene_from``), which must be of the
        frames' size and units, or learned from its frames."""
        if self.settings.scene_from is None:
            return SceneReference(scale, self.settings.scene_settings)
        if self._stored is None:
            self._stored = StoredScene.load(self.settings.scene_from)
        st = self._stored
        st.check_fits(shape, scale, self.settings.scene_from)
        return SceneReference.from_stored(st, self.settings.scene_settings)

    def _weigh(self, raw: np.ndarray, flagged: bool, ev: Evidence) -> bool:
        """The detector's verdict weighed against the frame's (``_in_units``) scene evidence; the reference
        takes the frame if clean."""
        if ev.usable:
            quiet = ev.dense < self.settings.scene_settings.quiet  # a flag on a quiet frame is a false alarm
            flagged = (flagged and not quiet) or ev.evident
        if not flagged:
            assert self._reference is not None
            self._reference.add(raw)
        return flagged

    def _remember(self, raw: np.ndarray, metres: np.ndarray, clean: bool) -> None:
        """What the next frame's models see: this frame (temporal detector) and, when the detector passed
        it, the last clean frame (temporal recovery)."""
        self._last = (raw.shape, metres)
        if clean and getattr(self.backend, "frames", 1) > 1:
            self._last_clean = metres

    def _buffer(self, flagged: bool, slot: int | None) -> None:
        self._slotted = slot is not None
        self._flags[slot if slot is not None else self._count] = flagged
        self._count += 1
        if slot is None and self._count == self.controller.active_frames:
            self.end_period()

    def end_period(self) -> int:
        """Hand the window's flags (window order; a missing frame counts as clean) to the controller and
        the new offset to the trigger."""
        c = self.controller
        if self._slotted:
            keys = (c.offset + np.arange(c.active_frames)) % c.total_frames
        else:
            keys = np.arange(c.active_frames)
        new = c.update([self._flags.get(int(k), False) for k in keys])
        self._flags.clear()
        self._count = 0
        self.period += 1
        if self.trigger is not None:
            self.trigger.set_offset(self.period, new)
        return new


#: Why a frame is flagged or not: no flag (""); the detector's score reached the threshold ("detector");
#: the sensor's scene found fresh interference the detector did not ("scene"), or both did
#: ("detector+scene"); the detector's score reached the threshold but the frame matches the scene's clean
#: frames, so the flag was dropped ("cleared by scene").
REASONS = ("", "detector", "scene", "detector+scene", "cleared by scene")


def _reason(detector: bool, flagged: bool, ev: Evidence | None) -> str:
    """Why the verdict: ``detector``: the detector's score reached the threshold; ``ev``: the frame's scene
    evidence (usable or not)."""
    scene = ev is not None and ev.usable
    if not flagged:
        return REASONS[4] if detector and scene else REASONS[0]
    if ev is None or not scene or not ev.evident:
        return REASONS[1]
    return REASONS[3] if detector else REASONS[2]


def _decides(ev: Evidence) -> bool:
    """The scene's evidence settles the verdict alone (``SensorLoop._weigh``): fresh deviations in patches
    flag the frame whatever the detector says; a frame that matches its scene is clean whatever it says."""
    quiet = ev.parts is not None and ev.dense < ev.parts.settings.quiet
    return ev.usable and (quiet or ev.evident)


def _in_units(raw: np.ndarray, scale: float) -> tuple[np.ndarray, float]:
    """A frame as the scene references take it: uint16 units; a frame in metres is judged in millimetres."""
    if raw.dtype == np.uint16:
        return raw, scale
    return np.clip(np.rint(np.nan_to_num(raw) * 1000), 0, 65535).astype(np.uint16), 1000.0
