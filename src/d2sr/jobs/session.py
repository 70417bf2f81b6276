"""Whole runs behind ``d2sr run``: a simulated room (closed loop) or a recording (open loop), written
into a ``RunFolder``, measured into ``RunStats``."""

from __future__ import annotations

import contextlib
import itertools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import TOTAL_FRAMES, make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Frames, Intrinsics, to_metres, to_units
from d2sr.jobs.output import RunFolder, SynthFrame
from d2sr.jobs.report import Report
from d2sr.jobs.sources import RoomTrigger, run_room
from d2sr.jobs.stats import RunStats
from d2sr.runtime.backends import Backend
from d2sr.runtime.loop import Capture, Result, SensorLoop
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.sim.lockstep import SimRoom, SlotEnd
from d2sr.sim.record import EPOCH_NS
from d2sr.sim.timing import TimingSettings
from d2sr.sim.world import Rig, make_rig
from d2sr.synth import Filler, Pose
from d2sr.synth.gaps import interleave

__all__ = ["Recording", "odometry", "rig_intrinsics", "run_recording", "run_sim", "slot_fill", "summarize"]

Progress = Callable[[float], None]


def run_sim(
    backend: Backend,
    out: Path | None,
    settings: RunSettings | None = None,
    loop_settings: LoopSettings | None = None,
    *,
    timing: TimingSettings | None = None,
    render: bool = True,
    progress: Progress | None = None,
    on_result: Callable[[int, Result], None] | None = None,
) -> dict[str, Any]:
    """``loop_settings.sensors`` simulated L515s in one room, each its own loop (``settings``: its repair
    and threshold; the scene is not judged); returns the summary (per sensor and all together). With
    ``out``, every sensor's frames, masks and log are written (a rerun starts clean: the world's state is
    not resumable), and report.html over all sensors (``loop_settings.report``). With its ``fill``: every
    slot without a frame (the laser off, or a frame dropped) is synthesized from the sensor's last frame and
    its odometry (``d2sr.synth``) and written with the others (needs ``out``)."""
    s = settings if settings is not None else RunSettings()
    ls = loop_settings if loop_settings is not None else LoopSettings()
    controller, sensors, seconds, active_frames = ls.controller, ls.sensors, ls.seconds, ls.active_frames
    seed, moving, fill, repair, threshold = ls.seed, ls.moving, ls.fill, s.repair, s.threshold
    if fill and (out is None or not render):
        raise ConfigError("fill writes synthesized frames into a run folder: it needs out and rendering")
    cfg = TimingSettings.make(
        **((timing or TimingSettings()).model_dump() | {"active_frames": active_frames})
    )
    rig = make_rig(seed, sensors=sensors, moving_robot=moving)
    room = SimRoom(rig, cfg, seed=seed, seconds=seconds, render=render)
    logged = {
        "source": "sim",
        "controller": controller,
        "sensors": sensors,
        "seconds": seconds,
        "active_frames": active_frames,
        "seed": seed,
        "moving": moving,
        "repair": repair,
        "threshold": threshold if threshold is not None else backend.threshold,
        "backend": backend.name,
        "timing": cfg.model_dump(),
        "fill": fill,
    }
    stats = [RunStats() for _ in range(sensors)]
    offsets: list[list[int]] = [[] for _ in range(sensors)]
    folder = RunFolder(out, logged, resumable=False, fill=fill) if out is not None else None
    fillers = [Filler(rig_intrinsics(rig)) for _ in range(sensors)] if fill else []
    synthesized = [0] * sensors
    report = (
        Report(f"d2sr run sim ({sensors} sensors)") if ls.report and folder is not None and render else None
    )
    with folder or contextlib.nullcontext():
        loops = [
            SensorLoop(
                backend,
                make_controller(controller, cfg.total_frames, active_frames, seed=seed * 1_000_003 + i),
                RoomTrigger(room, i),
                sink=folder.sink(i) if folder is not None else None,
                settings=RunSettings(threshold=threshold, repair=repair if render else "none", scene=False),
            )
            for i in range(sensors)
        ]
        for ev, res in run_room(room, loops, seconds, progress):
            if res is not None:
                stats[ev.sensor].add(res)
                if report is not None:
                    report.add(res, f"sensor {ev.sensor}, slot {res.capture.name}")
                if on_result is not None:
                    on_result(ev.sensor, res)
            if fill and folder is not None:
                _fill(room, rig, fillers[ev.sensor], folder, ev, res)
                synthesized[ev.sensor] += res is None
            if ev.period_end:
                offsets[ev.sensor].append(room.offset(ev.sensor, ev.slot // cfg.total_frames))
        summary = summarize(logged, stats)
        summary["offsets"] = offsets
        summary["phases_s"] = [round(float(t), 6) for t in room.t0]
        summary["drifts"] = [float(d) for d in room.drift]
        if fill:
            summary["synthesized"] = synthesized
        if folder is not None:
            if report is not None:
                report.write(folder.partial / "report.html")
            folder.finish(summary)
    return summary


def odometry(rig: Rig, sensor: int, t: float) -> Pose:
    """Sensor ``sensor``'s camera-to-world pose at ``t`` s, as a robot's odometry would give it."""
    p = rig.pose(sensor, t)
    return Pose(p.axes().T, p.position)


def rig_intrinsics(rig: Rig) -> Intrinsics:
    """The rig's camera as the warp takes it: the renderer's pixel centres sit half a pixel off."""
    k = rig.intr
    return Intrinsics(k.width, k.height, k.fx, k.fy, k.px - 0.5, k.py - 0.5)


def _fill(
    room: SimRoom, rig: Rig, filler: Filler, folder: RunFolder, ev: SlotEnd, res: Result | None
) -> None:
    """A sensor's slot for ``run_sim(fill=True)``: its delivered frame becomes the filler's source, or the
    slot is synthesized from the last one and written."""
    i, scale, total = ev.sensor, room.model.depth_scale, room.cfg.total_frames
    start = ev.time_s - float(room.tau[i])  # a slot's frame is taken at its start
    if res is not None:  # what the sensor gave (repaired where flagged)
        filler.real(to_metres(res.depth, scale), pose=odometry(rig, i, start))
        return
    period, k = ev.slot // total, rig.intr
    where = (period, ev.slot % total, room.offset(i, period))
    stamp = EPOCH_NS + round(start * 1e9)
    pose = odometry(rig, i, start)
    frame = slot_fill(filler, f"{ev.slot:06d}", stamp, where, (k.height, k.width), scale, pose=pose)
    folder.write_synthesized(i, frame)


def slot_fill(
    filler: Filler,
    name: str,
    stamp: int | None,
    where: tuple[int, int | None, int],
    shape: tuple[int, int],
    scale: float,
    colour: np.ndarray | None = None,
    pose: Pose | None = None,
) -> SynthFrame:
    """The frame ``filler`` synthesizes for a slot without one (``where``: its period, slot and the window
    offset), in the run's units; an empty one with confidence 0 when no real frame came yet."""
    t0 = time.perf_counter()
    try:
        s = filler.synthesize(colour, pose)
        depth, conf = to_units(s.depth, scale), s.confidence
    except InputError:  # no frame yet to synthesize from
        depth, conf = np.zeros(shape, np.uint16), np.zeros(shape, np.float32)
    return SynthFrame(name, depth, conf, stamp, *where, 1000 * (time.perf_counter() - t0))


class RunFiller:
    """Synthesis inside a run folder (a recording's or a camera's run with fill): each frame the run wrote
    becomes the source, and each moment the laser skipped is written as ``<last frame>_<k>``."""

    def __init__(self, folder: RunFolder, intrinsics: Intrinsics | None, sensor: int = 0) -> None:
        self.folder, self.sensor = folder, sensor
        self.filler = Filler(intrinsics)
        self.made = 0
        self._last, self._since = "start", 0

    def real(self, name: str, res: Result, scale: float, colour: np.ndarray | None) -> None:
        self.filler.real(to_metres(res.depth, scale), colour)
        self._last, self._since = name, 0

    def skipped(
        self, colour: np.ndarray, stamp: int | None, where: tuple[int, int | None, int], scale: float
    ) -> None:
        self._since += 1
        shape = (colour.shape[0], colour.shape[1])  # depth is aligned to colour
        name = f"{self._last}_{self._since:02d}"
        f = slot_fill(self.filler, name, stamp, where, shape, scale, colour=colour)
        self.folder.write_synthesized(self.sensor, f)
        self.made += 1


@dataclass(frozen=True)
class Recording:
    """A recording ``run_recording`` replays: its frames (``scale`` units per metre), what the log calls it
    (``source``), and its colour stream where frames are synthesized for the slots the laser skipped:
    ``(stamp ns, image)`` in time order, depth aligned to it."""

    frames: Frames
    scale: float
    source: str
    colours: Iterable[tuple[int, np.ndarray]] | None = None


def run_recording(
    backend: Backend,
    recording: Recording,
    out: Path,
    settings: RunSettings | None = None,
    loop_settings: LoopSettings | None = None,
    *,
    progress: Progress | None = None,
    on_result: Callable[[int, Result], None] | None = None,
) -> dict[str, Any]:
    """A recording through one loop (open loop: the controller's offsets are logged, not applied); with
    ``settings.scene``, a still sensor's frames are also judged against its scene (primed on the first
    ``settings.prime`` frames, as ``recover`` primes it) and repaired from it.
    A killed run resumes: logged frames are skipped and the controller is replayed from their flags.

    With the recording's colours, every colour frame no depth frame joins (a slot the laser skipped,
    ``d2sr.synth.interleave``) gets a frame synthesized from the last one and the colour stream (with the
    reader's intrinsics, else guessed), written with the others; such a run starts over when killed."""
    s = settings if settings is not None else RunSettings()
    ls = loop_settings if loop_settings is not None else LoopSettings()
    reader, scale, colours, intrinsics = recording.frames, recording.scale, recording.colours, None
    intrinsics = getattr(reader, "intrinsics", None)
    controller, active_frames, seed = ls.controller, ls.active_frames, ls.seed
    repair, threshold, scene, source = s.repair, s.threshold, s.scene, recording.source
    fill = colours is not None
    logged = {
        "source": source,
        "frames": len(reader),
        "depth_scale": scale,
        "controller": controller,
        "active_frames": active_frames,
        "seed": seed,
        "repair": repair,
        "threshold": threshold if threshold is not None else backend.threshold,
        "backend": backend.name,
        "scene": scene,
        "prime": s.prime if scene else 0,
        "fill": fill,
    }
    stats = RunStats()
    total = len(reader)
    with RunFolder(out, logged, resumable=not fill, fill=fill) as folder:
        ctrl = make_controller(controller, TOTAL_FRAMES, active_frames, seed=seed)
        loop = SensorLoop(
            backend,
            ctrl,
            None,
            folder.sink(0),
            settings=live_settings(s),
        )
        filler = RunFiller(folder, intrinsics)
        done = folder.done
        report = Report(f"d2sr run {source}") if ls.report else None
        # As recover does: the scene first learns from the recording's frames ahead (the sensor's own).
        loop.prime([Capture(f, scale) for f in itertools.islice(reader, s.prime)])
        frames = interleave(reader, colours) if colours is not None else ((f, None, 0) for f in reader)
        k = 0
        for frame, colour, stamp in frames:
            if frame is None:  # a moment the laser skipped: colour alone
                assert colour is not None
                filler.skipped(colour, stamp, (loop.period, None, loop.controller.offset), scale)
                continue
            cap = Capture(frame, scale)
            rec = done.get((0, cap.name))
            if rec is not None:  # resumed: replay the controller from the logged flag
                loop.replay(bool(int(rec["flagged"])), cap=cap)
            else:
                res = loop.process(cap)
                stats.add(res)
                if report is not None:
                    report.add(res)
                if on_result is not None:
                    on_result(0, res)
                if fill:
                    filler.real(frame.name, res, scale, colour)
            k += 1
            if progress is not None:
                progress(k / total)
        summary = summarize(logged, [stats]) | {"resumed_frames": len(done)}
        if fill:
            summary["synthesized"] = [filler.made]
        if report is not None:  # what this run (since a resume, the frames after it) did
            report.write(folder.partial / "report.html")
        folder.finish(summary)
    return summary


def summarize(settings: dict[str, Any], stats: list[RunStats]) -> dict[str, Any]:
    """The run's summary: settings, all sensors together, and each sensor."""
    allst = stats[0]
    for s in stats[1:]:
        allst = allst.merge(s)
    return {"settings": settings, "all": allst.summary(), "sensors": [s.summary() for s in stats]}


def live_settings(s: RunSettings) -> RunSettings:
    """A stream's settings for its loop: the scene repairs whatever is repaired, unless told otherwise."""
    return s if s.scene_repair is not None else s.model_copy(update={"scene_repair": s.scene})
