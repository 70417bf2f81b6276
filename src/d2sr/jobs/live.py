"""A live camera through one loop: a RealSense (pyrealsense2) or an Orbbec (pyorbbecsdk2), closed through an
actuator (``d2sr.triggers``) when one is given, else open loop (the window is only logged and the camera
keeps streaming; detection and repair still run). Untested against hardware: the loop, clock, output and
statistics are the tested ones, and what stays untested is listed in docs/hardware.md."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import TOTAL_FRAMES, make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Frame, Intrinsics
from d2sr.frames.realsense import import_rs
from d2sr.jobs.output import RunFolder
from d2sr.jobs.report import Report
from d2sr.jobs.session import RunFiller, live_settings, summarize
from d2sr.jobs.shots import Shot, host_arrival, rgbd_shots
from d2sr.jobs.stats import RunStats
from d2sr.runtime.backends import Backend
from d2sr.runtime.closed import ClosedLoop
from d2sr.runtime.loop import Capture, Result, SensorLoop
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.triggers import Actuator, open_trigger, parse_trigger

__all__ = ["CAMERAS", "check_camera", "run_live"]

CAMERAS = ("realsense", "orbbec")

LiveFrames = Iterator[Shot]  # in time order; a shot of colour alone: a moment the laser skipped


def check_camera(source: str, trigger: str | None, fill: bool = False) -> tuple[str, str | None]:
    """``realsense[:SERIAL]`` / ``orbbec[:SERIAL]`` and a trigger that can drive it -> (camera, serial);
    ``fill`` (colour read for synthesis) needs a RealSense."""
    camera, _, serial = source.partition(":")
    if camera not in CAMERAS:
        raise ConfigError(f"unknown camera {camera!r}; choose from {', '.join(CAMERAS)}")
    if fill and camera != "realsense":
        raise ConfigError(
            "fill on a live camera: a RealSense for now (an Orbbec: the ROS 2 node with its colour topic)",
            "fill",
        )
    if trigger is not None:
        kind = parse_trigger(trigger)[0]
        own = {"orbbec": "orbbec", "realsense-emitter": "realsense"}.get(kind, camera)
        if own != camera:
            raise ConfigError(f"trigger {kind} drives its own camera kind, not a {camera} camera", "trigger")
    return camera, serial or None


def _realsense(
    serial: str | None, actuator: Actuator | None, trigger: str | None, seconds: float, colour: bool
) -> tuple[LiveFrames, Intrinsics | None]:
    """A started RealSense's shots, waiting for its sync input or with its emitter driven when an actuator
    is given; with ``colour``, its colour stream too (``shots.rgbd_shots``) and the intrinsics of the
    depth aligned to it."""
    rs = import_rs()
    ctx = rs.context()
    devices = {d.get_info(rs.camera_info.serial_number): d for d in ctx.query_devices()}
    if not devices:
        raise InputError("no RealSense device connected")
    if serial is not None and serial not in devices:
        raise InputError(f"no RealSense with serial {serial}; connected: {', '.join(devices)}")
    device = devices[serial] if serial is not None else next(iter(devices.values()))
    sensor = device.first_depth_sensor()
    if actuator is not None and trigger is not None:
        kind, _, sync = parse_trigger(trigger)
        if kind == "realsense-emitter":
            actuator.attach(sensor)  # type: ignore[attr-defined]
        elif sync.rs_mode is not None and sensor.supports(rs.option.inter_cam_sync_mode):
            sensor.set_option(rs.option.inter_cam_sync_mode, sync.rs_mode)
    if colour:
        return rgbd_shots(sensor, device.first_color_sensor(), seconds)
    pipe, cfg = rs.pipeline(ctx), rs.config()
    cfg.enable_device(device.get_info(rs.camera_info.serial_number))
    cfg.enable_stream(rs.stream.depth, rs.format.z16, 30)
    pipe.start(cfg)
    return _realsense_frames(pipe, 1.0 / sensor.get_depth_scale(), seconds), None


def _realsense_frames(pipe: Any, scale: float, seconds: float) -> LiveFrames:
    rs = import_rs()
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            ok, fs = pipe.try_wait_for_frames(200)
            if not ok:
                continue  # a triggered camera sends nothing outside its window
            d = fs.get_depth_frame()
            stamp = int(d.get_timestamp() * 1e6)
            frame = Frame(f"{d.get_frame_number():08d}", np.asanyarray(d.get_data()).copy(), stamp)
            yield Shot(frame, scale, host_arrival(d, rs), None, stamp)
    finally:
        pipe.stop()


def _camera(
    camera: str,
    serial: str | None,
    seconds: float,
    actuator: Actuator | None,
    trigger: str | None,
    fill: bool,
) -> tuple[LiveFrames, Intrinsics | None]:
    """The camera's moments, and with ``fill`` (a RealSense: ``check_camera``) the intrinsics of the depth
    aligned to its colour."""
    if camera == "realsense":
        return _realsense(serial, actuator, trigger, seconds, fill)
    from d2sr.triggers.orbbec import OrbbecActuator, open_orbbec, orbbec_frames

    triggered = isinstance(actuator, OrbbecActuator)
    device, pipe = open_orbbec(serial, triggered)
    if triggered:
        actuator.device = device  # type: ignore[union-attr]
    return (Shot(f, scale, arrival) for f, scale, arrival in orbbec_frames(pipe, seconds)), None


def run_live(
    backend: Backend,
    out: Path,
    source: str,
    settings: RunSettings | None = None,
    loop_settings: LoopSettings | None = None,
    *,
    on_result: Callable[[int, Result], None] | None = None,
) -> dict[str, Any]:
    """A live camera (``realsense[:SERIAL]`` or ``orbbec[:SERIAL]``) through one loop for
    ``loop_settings.seconds``; closed through its ``trigger`` (a ``d2sr.triggers`` spec) when given; with
    ``settings.scene``, a still camera's frames are also judged against its scene. With its ``fill`` (a
    RealSense), the colour stream is read too, and every colour frame that no depth frame joins (the laser
    was off) gets a frame synthesized from the last one, written into the run with its confidence."""
    s = settings if settings is not None else RunSettings()
    ls = loop_settings if loop_settings is not None else LoopSettings()
    trigger, controller, seconds, fill, scene = ls.trigger, ls.controller, ls.seconds, ls.fill, s.scene
    camera, serial = check_camera(source, trigger, fill)
    stats = RunStats()
    logged = {
        "source": source,
        "trigger": trigger,
        "controller": controller,
        "seconds": seconds,
        "scene": scene,
        "fill": fill,
    }
    actuator = open_trigger(trigger, ls.active_frames) if trigger is not None else None
    with contextlib.ExitStack() as stack:
        if actuator is not None:
            stack.callback(actuator.close)
        shots, intrinsics = _camera(camera, serial, seconds, actuator, trigger, fill)
        folder = stack.enter_context(RunFolder(out, logged, resumable=False, fill=fill))
        ctrl = make_controller(controller, TOTAL_FRAMES, ls.active_frames, seed=ls.seed)
        one = SensorLoop(backend, ctrl, None, folder.sink(0), settings=live_settings(s))
        closed = ClosedLoop(one, actuator) if actuator is not None else None
        report = Report(f"d2sr run {source}") if ls.report else None
        filler = RunFiller(folder, intrinsics)
        for shot in shots:
            if shot.depth is None:  # colour alone: a moment the laser skipped
                if fill and shot.colour is not None:
                    where = actuator.locate(shot.arrival) if actuator is not None else (one.period, None)
                    filler.skipped(shot.colour, shot.stamp, (*where, one.controller.offset), shot.scale)
                continue
            cap = Capture(shot.depth, shot.scale)
            res = one.process(cap) if closed is None else closed.process(cap, shot.arrival)
            stats.add(res)
            if report is not None:
                report.add(res)
            if on_result is not None:
                on_result(0, res)
            if fill:
                filler.real(shot.depth.name, res, shot.scale, shot.colour)
        summary = summarize(logged, [stats])
        if fill:
            summary["synthesized"] = [filler.made]
        if report is not None:
            report.write(folder.partial / "report.html")
        folder.finish(summary)
    return summary
