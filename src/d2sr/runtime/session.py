"""Whole runs behind ``d2sr run``: a simulated room (closed loop) or a recording (open loop), written
into a ``RunFolder``, measured into ``RunStats``."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import TOTAL_FRAMES, make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Frames, Intrinsics, to_metres, to_units
from d2sr.runtime.backends import Backend
from d2sr.runtime.loop import Result, SensorLoop
from d2sr.runtime.output import RunFolder, SynthFrame
from d2sr.runtime.sources import RoomTrigger, recording, run_room
from d2sr.runtime.stats import RunStats
from d2sr.sim.record import EPOCH_NS
from d2sr.sim.room import SimRoom, SlotEnd
from d2sr.sim.timing import TimingConfig
from d2sr.sim.world import Rig, make_rig
from d2sr.synth import Filler, Pose

__all__ = ["odometry", "rig_intrinsics", "run_recording", "run_sim", "summarize"]

Progress = Callable[[float], None]


def run_sim(
    backend: Backend,
    out: Path | None,
    controller: str,
    sensors: int = 3,
    seconds: float = 20.0,
    active_frames: int = 6,
    seed: int = 0,
    moving: bool = False,
    repair: str = "flagged",
    threshold: float | None = None,
    timing: TimingConfig | None = None,
    render: bool = True,
    progress: Progress | None = None,
    on_result: Callable[[int, Result], None] | None = None,
    fill: bool = False,
) -> dict[str, Any]:
    """``sensors`` simulated L515s in one room, each its own loop; returns the summary (per sensor and
    all together). With ``out``, every sensor's frames, masks and log are written (a rerun starts clean:
    the world's state is not resumable). ``fill``: every slot without a frame (the laser off, or a frame
    dropped) is synthesized from the sensor's last frame and its odometry (``d2sr.synth``) and written
    with the others (needs ``out``)."""
    if fill and (out is None or not render):
        raise ConfigError("fill writes synthesized frames into a run folder: it needs out and rendering")
    cfg = TimingConfig.make(**((timing or TimingConfig()).model_dump() | {"active_frames": active_frames}))
    rig = make_rig(seed, sensors=sensors, moving_robot=moving)
    room = SimRoom(rig, cfg, seed=seed, seconds=seconds, render=render)
    settings = {
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
    folder = RunFolder(out, settings, resumable=False, fill=fill) if out is not None else None
    fillers = [Filler(rig_intrinsics(rig)) for _ in range(sensors)] if fill else []
    synthesized = [0] * sensors
    with folder or contextlib.nullcontext():
        loops = [
            SensorLoop(
                backend,
                make_controller(controller, cfg.total_frames, active_frames, seed=seed * 1_000_003 + i),
                RoomTrigger(room, i),
                sink=folder.sink(i) if folder is not None else None,
                threshold=threshold,
                repair=repair if render else "none",
            )
            for i in range(sensors)
        ]
        for ev, res in run_room(room, loops, seconds, progress):
            if res is not None:
                stats[ev.sensor].add(res)
                if on_result is not None:
                    on_result(ev.sensor, res)
            if fill and folder is not None:
                _fill(room, rig, fillers[ev.sensor], folder, ev, res)
                synthesized[ev.sensor] += res is None
            if ev.period_end:
                offsets[ev.sensor].append(room.offset(ev.sensor, ev.slot // cfg.total_frames))
        summary = summarize(settings, stats)
        summary["offsets"] = offsets
        summary["phases_s"] = [round(float(t), 6) for t in room.t0]
        summary["drifts"] = [float(d) for d in room.drift]
        if fill:
            summary["synthesized"] = synthesized
        if folder is not None:
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
    t0 = time.perf_counter()
    try:
        s = filler.synthesize(pose=odometry(rig, i, start))
        depth, conf = to_units(s.depth, scale), s.confidence
    except InputError:  # no frame yet to synthesize from: an empty one, confidence 0
        k = rig.intr
        depth, conf = np.zeros((k.height, k.width), np.uint16), np.zeros((k.height, k.width), np.float32)
    ms = 1000 * (time.perf_counter() - t0)
    period = ev.slot // total
    frame = SynthFrame(
        f"{ev.slot:06d}", depth, conf, EPOCH_NS + round(start * 1e9), period, ev.slot % total,
        room.offset(i, period), ms,
    )  # fmt: skip
    folder.write_synthesized(i, frame)


def run_recording(
    backend: Backend,
    reader: Frames,
    scale: float,
    out: Path,
    controller: str,
    source: str,
    active_frames: int = 6,
    repair: str = "flagged",
    threshold: float | None = None,
    seed: int = 0,
    progress: Progress | None = None,
    on_result: Callable[[int, Result], None] | None = None,
    scene: bool = False,
) -> dict[str, Any]:
    """A recording through one loop (open loop: the controller's offsets are logged, not applied); with
    ``scene``, a still sensor's frames are also judged against its scene (``SensorLoop.scene``).
    A killed run resumes: logged frames are skipped and the controller is replayed from their flags."""
    settings = {
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
    }
    stats = RunStats()
    total = len(reader)
    with RunFolder(out, settings, resumable=True) as folder:
        ctrl = make_controller(controller, TOTAL_FRAMES, active_frames, seed=seed)
        loop = SensorLoop(backend, ctrl, None, folder.sink(0), threshold, repair, scene=scene)
        done = folder.done
        for k, cap in enumerate(recording(reader, scale)):
            rec = done.get((0, cap.name))
            if rec is not None:  # resumed: replay the controller from the logged flag
                loop.replay(bool(int(rec["flagged"])), cap=cap)
            else:
                res = loop.process(cap)
                stats.add(res)
                if on_result is not None:
                    on_result(0, res)
            if progress is not None:
                progress((k + 1) / total)
        summary = summarize(settings, [stats]) | {"resumed_frames": len(done)}
        folder.finish(summary)
    return summary


def summarize(settings: dict[str, Any], stats: list[RunStats]) -> dict[str, Any]:
    """The run's summary: settings, all sensors together, and each sensor."""
    allst = stats[0]
    for s in stats[1:]:
        allst = allst.merge(s)
    return {"settings": settings, "all": allst.summary(), "sensors": [s.summary() for s in stats]}
