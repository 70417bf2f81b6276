"""The library's face: ``repair`` mends one frame, ``Pipeline`` runs one sensor's loop (detect, controller,
repair, the temporal models' last clean frame). Torch-free on an edge install (onnxruntime).

Depth in: ``uint16`` in sensor units (``depth_scale`` units per metre, default 1000: millimetres) comes
back ``uint16`` in the same units; ``float32``/``float64`` is metres (NaN, inf and 0 = no return) and comes
back as metres of the same type. Only the repaired pixels (``mask``) differ from the input.
"""

from __future__ import annotations

import functools
import itertools
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from d2sr.desync import CONTROLLERS, TOTAL_FRAMES, make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import PLAUSIBLE_M, Frame, Intrinsics, probe, to_units
from d2sr.frames.encoded import check_pixels
from d2sr.runtime.backends import Backend
from d2sr.runtime.closed import ClosedLoop
from d2sr.runtime.loop import Capture, Decision, Result, SensorLoop, Trigger
from d2sr.runtime.settings import DesyncSettings, RunSettings
from d2sr.synth import Filler, Pose, Synthesized
from d2sr.triggers import Actuator, open_trigger

S = TypeVar("S", DesyncSettings, RunSettings)  # a settings object the library takes, fields over it

__all__ = [
    "Decided",
    "Pipeline",
    "Repaired",
    "Window",
    "model_settings",
    "open_models",
    "repair",
    "settings_of",
]


@dataclass(frozen=True)
class Window:
    """Where the sensor's laser is on: slots ``offset`` .. ``offset + active_frames - 1`` (mod
    ``total_frames``) of every 1 s period, from period ``period`` on."""

    period: int
    offset: int
    active_frames: int
    total_frames: int = TOTAL_FRAMES

    def active(self, slot: int) -> bool:
        """Whether slot ``slot`` of a period lies in the window."""
        return (slot - self.offset) % self.total_frames < self.active_frames


@dataclass(frozen=True)
class Repaired:
    """One frame after d2sr.

    - ``depth``: the frame, repaired inside ``mask`` and bit for bit the input elsewhere; same dtype and
      units as the input.
    - ``mask``: bool, True where a pixel was repaired.
    - ``interfered``: the detector flagged the frame (its score reached the threshold), or with ``scene``
      the frame's scene evidence decided.
    - ``score``: the detector's probability that the frame is interfered, in [0, 1]; NaN where no detector
      ran (with ``scene``, a frame its scene evidence decides alone is not scored).
    - ``window``: the active window the sensor ran this frame's period with (``Pipeline`` only).
    - ``seconds``: detect + repair time of this frame.
    - ``scene``: the sensor's scene weighed the verdict (True), or it was still being built or the sensor
      moved, and the detector decided alone (False); None with ``scene=False``.
    - ``reason``: why the verdict: "" (clean), "detector", "scene", "detector+scene" or "cleared by scene"
      (the detector's score reached the threshold, but the frame matches the sensor's clean frames).
    """

    depth: np.ndarray
    mask: np.ndarray
    interfered: bool
    score: float
    window: Window | None = None
    seconds: float = 0.0
    scene: bool | None = None
    reason: str = ""


@dataclass(frozen=True)
class Decided:
    """A frame ``Pipeline.decide`` judged, waiting for ``Pipeline.finish``."""

    depth: np.ndarray
    decision: Decision


# The type each argument of ``repair`` and ``Pipeline`` outside the settings must have.
_TYPES: dict[str, tuple[type, ...]] = {
    "depth_scale": (int, float),
}
_OPTIONAL = {"depth_scale"}


def check_types(**arguments: object) -> None:
    """Each argument of the library's entry points of its type (a ConfigError naming it otherwise), numbers
    finite: a caller's mistake is one of d2sr's errors, not a TypeError from deep inside."""
    for name, value in arguments.items():
        want = _TYPES[name]
        if value is None and name in _OPTIONAL:
            continue
        numeric = want[0] is int or want[0] is float
        if (numeric and isinstance(value, bool)) or not isinstance(value, want):
            kind = ("a number" if numeric else " or ".join(t.__name__ for t in want)) + (
                " or None" if name in _OPTIONAL else ""
            )
            raise ConfigError(f"{name} must be {kind}, got {type(value).__name__} {str(value)[:40]!r}", name)
        if numeric and not np.isfinite(float(value)):  # type: ignore[arg-type]
            raise ConfigError(f"{name} must be a finite number, got {value}", name)


def _over(kind: type[S], given: S | None, options: dict[str, Any], name: str) -> S:
    """``given`` [``kind``'s defaults] with ``options`` (its fields by keyword) over it."""
    if given is not None and not isinstance(given, kind):
        raise ConfigError(f"{name} must be {kind.__name__}, got {type(given).__name__}", name)
    if not options:
        return given if given is not None else kind()
    kept = {k: getattr(given, k) for k in given.model_fields_set} if given is not None else {}
    return kind(**(kept | options))


def desync_of(desync: DesyncSettings | None, options: dict[str, Any]) -> DesyncSettings:
    """``desync`` [the defaults] with ``options`` (``DesyncSettings`` fields by keyword) over it."""
    return _over(DesyncSettings, desync, options, "desync")


def settings_of(settings: RunSettings | None, options: dict[str, Any]) -> RunSettings:
    """``settings`` [the defaults] with ``options`` (``RunSettings`` fields by keyword) over it."""
    unknown = sorted(set(options) - set(RunSettings.model_fields))
    if unknown and (settings is None or isinstance(settings, RunSettings)):
        raise ConfigError(f"unknown setting {unknown[0]!r}; settings: {', '.join(RunSettings.model_fields)}")
    return _over(RunSettings, settings, options, "settings")


@functools.lru_cache(maxsize=4)
def open_models(
    settings: RunSettings | None = None, *, detector: bool = True, recovery: bool = True
) -> Backend:
    """``open_backend``'s models, opened once per set of arguments and shared (sessions are safe to run
    from several threads)."""
    from d2sr.runtime.backends import open_backend

    return open_backend(settings, detector=detector, recovery=recovery)


def _models(s: RunSettings) -> Backend:
    """The models a frame-by-frame repair in ``s`` needs: no recovery model when it repairs none."""
    if not s.models.is_dir():
        raise InputError(f"{s.models}: no such models folder")
    return open_models(model_settings(s), recovery=s.repair != "none")


def model_settings(s: RunSettings) -> RunSettings:
    """``s`` with only the fields that choose and open models set: one cache entry per set of models."""
    keep = ("model", "models", "backend", "mask_logit", "passes", "threads", "int8")
    return RunSettings(**{k: getattr(s, k) for k in keep})


def _as_frame(depth: object, depth_scale: float | None, name: str) -> tuple[np.ndarray, float]:
    """The loop's view of a caller's array: (uint16 units or float32 metres with NaN/inf as 0, scale)."""
    if not isinstance(depth, np.ndarray):
        raise InputError(f"{name}: depth must be a numpy array, got {type(depth).__name__}")
    if depth.ndim != 2:
        raise InputError(f"{name}: depth must be a 2-D image, got shape {'x'.join(map(str, depth.shape))}")
    check_pixels(depth.shape[0], depth.shape[1], name)  # every frame: a stream may change size
    if depth.dtype.kind == "f":
        check_types(depth_scale=depth_scale)
        if depth_scale not in (None, 1, 1.0):
            raise InputError(f"{name}: float depth is metres; depth_scale applies to uint16 frames only")
        metres = np.where(np.isfinite(depth), depth, 0).astype(np.float32)
        if (metres < 0).any():
            raise InputError(f"{name}: depth has negative values")
        return metres, 1.0
    if depth.dtype != np.uint16:
        raise InputError(f"{name}: depth must be uint16 (sensor units) or float (metres), got {depth.dtype}")
    check_types(depth_scale=depth_scale)
    scale = 1000.0 if depth_scale is None else float(depth_scale)
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"depth_scale must be a positive number, got {depth_scale}")
    return depth, scale


def _probe(depth: np.ndarray, scale: float, name: str) -> None:
    """A scale that makes indoor sense (an InputError when far off); doubts become Python warnings."""
    for w in probe([Frame(name, depth)], scale, PLAUSIBLE_M[1]):
        warnings.warn(f"d2sr: {w}", stacklevel=3)


def _back(depth: np.ndarray, res: Result) -> np.ndarray:
    """The result in the caller's dtype: the input itself outside the mask (NaN kept), the repair inside."""
    if depth.dtype == res.depth.dtype:
        return res.depth if depth.dtype == np.uint16 else np.where(res.mask, res.depth, depth)
    out = depth.copy()
    out[res.mask] = res.depth[res.mask]
    return out


class Pipeline:
    """One sensor's stateful loop, the runtime ``d2sr run`` and ``d2sr recover`` use: each frame is scored
    by the detector, its flag fed to the de-synchronization controller (one decision per period of
    ``active_frames`` frames), and repaired when flagged (``repair="flagged"``), always (``"all"``) or
    never (``"none"``). Temporal models see the last frame the detector passed.

    - ``depth_scale``: units per metre of uint16 frames (default 1000; raw L515 4000); float frames are
      metres.
    - ``desync``: ``DesyncSettings`` [the defaults: controller "robust", 6 active frames of 30, seed 0], and
      its fields by keyword over it (``active_frames=6``); ``trigger``: what
      moves the real sensor's window (none: the window is only reported). Either a ``d2sr.triggers`` spec
      (``"serial:/dev/ttyACM0"``, ``"gpio:gpiochip0:17@d400"``, ...) or an ``Actuator``: the loop is then
      closed, each frame's slot comes from the time ``process`` is called, and periods end on the
      actuator's clock. Or any object with ``set_offset(period, offset)``, given slots by the caller.
      Close a Pipeline with a trigger (``close`` or ``with``) to stop its clock.
    - ``threads``: onnxruntime's threads per model [the recovery model on all cores, the detector on one];
      ``int8``: the int8 models (``d2sr export --int8``).
    - ``intrinsics``: the depth camera's (``d2sr.frames.Intrinsics``), for ``synthesize`` [guessed].
    - ``scene`` [True]: frames are also judged against the scene the sensor's clean frames have shown
      (``d2sr.scene``), once it has held still: a flagged frame in which nothing deviates from it is
      passed, one with fresh patches off it, or a surface read a centimetre or more off as a whole, is
      flagged. While the sensor moves the detector decides alone.
      False: the detector alone, always.
    - ``scene_repair`` [True]: with ``scene``, a repaired frame takes the scene's own depth where it deviates
      freshly from a still scene that is trusted there, and the model leaves alone what reads as the scene
      (``SensorLoop.scene_repair``). False: the model alone repairs.
    - ``settings``: ``RunSettings`` [the defaults], and its fields by keyword (``model="unet8"``,
      ``threshold=0.6``, ``threads=2``, ...) over it. ``scene_repair`` [on with the scene, whatever
      ``repair``]: a repaired frame takes the scene's own depth where it deviates freshly from a still scene
      that is trusted there, and the model leaves alone what reads as the scene.
    """

    def __init__(
        self,
        depth_scale: float | None = None,
        *,
        settings: RunSettings | None = None,
        desync: DesyncSettings | None = None,
        trigger: Trigger | str | None = None,
        intrinsics: Intrinsics | None = None,
        **options: Any,
    ) -> None:
        check_types(depth_scale=depth_scale)
        if depth_scale is not None and depth_scale <= 0:
            raise ConfigError(f"depth_scale must be a positive number, got {depth_scale}", "depth_scale")
        d = desync_of(desync, {k: options.pop(k) for k in list(options) if k in DesyncSettings.model_fields})
        if d.controller == "oracle":
            names = ", ".join(c for c in CONTROLLERS if c != "oracle")
            msg = f"controller: unknown 'oracle' for one sensor; choose from {names}"
            raise ConfigError(msg, "controller")
        self.desync = d
        s = settings_of(settings, options)
        if s.scene_repair is None:  # a live stream's scene repairs whatever it repairs
            s = s.model_copy(update={"scene_repair": s.scene})
        self.settings = s
        self.depth_scale = depth_scale if depth_scale is not None else s.depth_scale
        self.backend = _models(s)
        if isinstance(trigger, str):
            trigger = open_trigger(trigger, d.active_frames)
        actuator = trigger if isinstance(trigger, Actuator) else None
        self.loop = SensorLoop(
            self.backend,
            make_controller(d.controller, TOTAL_FRAMES, d.active_frames, seed=d.seed),
            None if actuator is not None else trigger,
            settings=s,
        )
        self.closed = ClosedLoop(self.loop, actuator) if actuator is not None else None
        self._count = itertools.count()
        self._probed = False
        self._filler = Filler(intrinsics)
        # the last processed frame (repaired), its colour, dtype and scale: what synthesize starts from
        self._last: tuple[np.ndarray, np.ndarray | None, np.dtype[Any], float] | None = None
        self._last_pose: Pose | None = None
        self._fed = False

    def attach(self, device: Any) -> None:
        """Give a camera-bound trigger (``realsense-emitter``: the depth sensor; ``orbbec``: the device) the
        camera it acts on; until then such a trigger refuses to run frames rather than do nothing."""
        actuator = self.closed.actuator if self.closed is not None else None
        if actuator is None or not hasattr(actuator, "attach"):
            raise ConfigError("attach: this Pipeline has no camera-bound trigger")
        actuator.attach(device)

    def _check_bound(self) -> None:
        actuator = self.closed.actuator if self.closed is not None else None
        missing = getattr(actuator, "unbound", None)
        if missing:
            raise ConfigError(
                f"trigger {getattr(actuator, 'kind', '')}: nothing to act on yet; give it {missing} "
                "through Pipeline.attach before the first frame"
            )

    def close(self) -> None:
        """Stop the trigger's clock and release its device."""
        if self.closed is not None:
            self.closed.actuator.close()

    def __enter__(self) -> Pipeline:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def window(self) -> Window:
        """The window the sensor runs now (the next frame's period)."""
        c = self.loop.controller
        return Window(self.loop.period, c.offset, c.active_frames, c.total_frames)

    def process(
        self,
        depth: np.ndarray,
        timestamp_ns: int | None = None,
        slot: int | None = None,
        arrival_s: float | None = None,
        colour: np.ndarray | None = None,
        pose: Pose | None = None,
    ) -> Repaired:
        """Detect, de-synchronize and repair one frame (frames in time order). ``slot``: where the frame
        lies in its 1 s period, for a sensor whose trigger sets it (None: every ``active_frames`` frames
        make a period; with an actuator, its clock tells from ``arrival_s``, the ``time.monotonic()`` at
        which the frame reached the host, by default now). ``colour``: the colour frame taken with it (depth
        aligned to colour), ``pose``: the camera's pose (odometry, camera to world), which ``synthesize``
        follows the camera with."""
        r = self.finish(self.decide(depth, timestamp_ns, slot, arrival_s))
        self.keep(r, colour, pose)
        return r

    def keep(self, r: Repaired, colour: np.ndarray | None = None, pose: Pose | None = None) -> None:
        """Remember a finished frame as the one ``synthesize`` starts from (``process`` does this; callers of
        ``decide``/``finish`` call it in frame order)."""
        scale = 1.0 if r.depth.dtype.kind == "f" else (self.depth_scale or 1000.0)
        # A copy: camera drivers reuse their buffers. The filler sees it only when synthesize needs it.
        self._last = (r.depth.copy(), None if colour is None else colour.copy(), r.depth.dtype, scale)
        self._last_pose = pose
        self._fed = False

    def synthesize(self, colour: np.ndarray | None = None, pose: Pose | None = None) -> Synthesized:
        """The frame the sensor would have given in a slot its laser skipped, from the last processed one
        (repaired) and the camera's motion: ``colour`` (the colour frame now) or ``pose`` (the camera's pose
        in the caller's world, for every frame; ``d2sr.synth.Pose``); with neither, that frame is held.
        ``depth`` comes back in the last frame's dtype and units (no value: 0, or NaN for float);
        ``confidence`` per pixel, ``method`` and ``since_real`` say how it was made (``d2sr.synth``)."""
        if self._last is None:
            raise InputError("synthesize: no frame processed yet to synthesize from")
        last, last_colour, dtype, scale = self._last
        if not self._fed:
            metres = np.where(np.isfinite(last), last, 0).astype(np.float32) / np.float32(scale)
            self._filler.real(metres, last_colour, self._last_pose)
            self._fed = True
        s = self._filler.synthesize(colour, pose)
        if dtype.kind == "f":
            depth = np.where(s.depth > 0, s.depth, np.nan).astype(dtype)
        else:
            depth = to_units(s.depth, scale)
        return Synthesized(depth, s.confidence, s.method, s.since_real)

    def prime(self, depths: Sequence[np.ndarray]) -> None:
        """For a recording: let the sensor's scene (``scene``) first learn from its opening frames, in time
        order, so that they too are judged against a scene rather than by the detector alone; then
        ``process`` the recording from its first frame. A live sensor starts cold instead. ``d2sr detect``
        and ``d2sr recover`` do this with the first ``PRIME_FRAMES`` (``SensorLoop.prime``)."""
        caps = []
        for i, depth in enumerate(depths):
            frame, scale = self._frame(depth, f"prime frame {i}")
            caps.append(Capture(Frame(f"prime{i:06d}", frame), scale))
        self.loop.prime(caps)

    def _frame(self, depth: np.ndarray, name: str) -> tuple[np.ndarray, float]:
        """``depth`` as the loop takes it (``_as_frame``); the first frame tells whether the scale makes
        sense (``_probe``)."""
        frame, scale = _as_frame(depth, self.depth_scale, name)
        if not self._probed:
            self._check_bound()
            _probe(frame, scale, name)
            self._probed = True
        return frame, scale

    def decide(
        self,
        depth: np.ndarray,
        timestamp_ns: int | None = None,
        slot: int | None = None,
        arrival_s: float | None = None,
    ) -> Decided:
        """The first half of ``process``, which must run in frame order: the detector's verdict and the
        controller's window.
        ``finish`` then repairs; several decided frames may be finished at once (on threads), so a live
        stream keeps its rate on several cores."""
        if slot is not None and self.closed is not None:
            raise ConfigError("slot: the actuator's clock gives each frame its slot; pass none")
        arrival = time.monotonic() if arrival_s is None else arrival_s
        k = next(self._count)
        frame, scale = self._frame(depth, f"frame {k}")
        cap = Capture(Frame(f"{k:06d}", frame, timestamp_ns), scale, slot)
        decision = self.loop.decide(cap) if self.closed is None else self.closed.decide(cap, arrival)
        return Decided(depth, decision)

    def finish(self, decided: Decided) -> Repaired:
        """The second half of ``process``: the repair of a decided frame."""
        res = self.loop.finish(decided.decision)
        window = Window(res.period, res.offset, self.loop.controller.active_frames, TOTAL_FRAMES)
        return Repaired(
            _back(decided.depth, res),
            res.mask,
            res.flagged,
            res.score,
            window,
            res.seconds,
            res.scene,
            res.reason,
        )

    def end_period(self) -> Window:
        """Close the observation period now (a triggered sensor whose last slots delivered no frame) and
        return the window the controller chose for the next. With an actuator its clock does this."""
        if self.closed is not None:
            raise ConfigError("end_period: the actuator's clock ends the periods")
        self.loop.end_period()
        return self.window


def repair(
    depth: np.ndarray, depth_scale: float | None = None, settings: RunSettings | None = None, **options: Any
) -> Repaired:
    """Detect and repair one depth frame: the repair ``d2sr recover`` gives that frame alone.

    ``depth``: uint16 in sensor units (``depth_scale`` units per metre; default 1000, millimetres) or float
    metres. Returns ``Repaired``: ``.depth`` (the input's dtype and units), ``.mask``, ``.interfered``,
    ``.score``. ``settings``: ``RunSettings`` [the defaults], and its fields by keyword over it
    (``repair="all"`` repairs the frame even when the detector passes it); a single frame has no scene.
    Models are opened on the first call and kept for the next ones; the depth scale is checked on the first
    frame given at that scale."""
    s = settings_of(settings, options)
    net = _models(s)
    frame, scale = _as_frame(depth, depth_scale if depth_scale is not None else s.depth_scale, "depth")
    units = (frame.dtype.str, scale)
    if units not in _PROBED:  # checked once per kind of units: a per-frame check would cost ~8 ms a frame
        _probe(frame, scale, "depth")
        _PROBED.add(units)
    alone = s.model_copy(update={"scene": False, "scene_repair": False})  # one frame: no scene to judge by
    loop = SensorLoop(net, make_controller("static", TOTAL_FRAMES, TOTAL_FRAMES), settings=alone)
    res = loop.process(Capture(Frame("frame", frame), scale))
    return Repaired(
        _back(depth, res), res.mask, res.flagged, res.score, None, res.seconds, res.scene, res.reason
    )


_PROBED: set[tuple[str, float]] = set()  # (dtype, depth scale) whose first frame passed the check
