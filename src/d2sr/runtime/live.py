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
from d2sr.frames.base import Frame
from d2sr.frames.realsense import import_rs
from d2sr.runtime.backends import Backend
from d2sr.runtime.closed import ClosedLoop
from d2sr.runtime.loop import Capture, Result, SensorLoop
from d2sr.runtime.output import RunFolder
from d2sr.runtime.session import summarize
from d2sr.runtime.stats import RunStats
from d2sr.triggers import Actuator, open_trigger, parse_trigger

__all__ = ["CAMERAS", "check_camera", "run_live"]

CAMERAS = ("realsense", "orbbec")

LiveFrames = Iterator[tuple[Frame, float, float]]  # frame, units per metre, host arrival (monotonic)


def check_camera(source: str, trigger: str | None) -> tuple[str, str | None]:
    """``realsense[:SERIAL]`` / ``orbbec[:SERIAL]`` and a trigger that can drive it -> (camera, serial)."""
    camera, _, serial = source.partition(":")
    if camera not in CAMERAS:
        raise ConfigError(f"unknown camera {camera!r}; choose from {', '.join(CAMERAS)}")
    if trigger is not None:
        kind = parse_trigger(trigger)[0]
        own = {"orbbec": "orbbec", "realsense-emitter": "realsense"}.get(kind, camera)
        if own != camera:
            raise ConfigError(f"--trigger {kind} drives its own camera kind, not a {camera} camera")
    return camera, serial or None


def _realsense(serial: str | None, actuator: Actuator | None, trigger: str | None) -> tuple[Any, Any]:
    """(pipeline, profile) of a started RealSense, waiting for its sync input or with its emitter driven
    when an actuator is given."""
    rs = import_rs()
    ctx = rs.context()
    serials = [d.get_info(rs.camera_info.serial_number) for d in ctx.query_devices()]
    if not serials:
        raise InputError("no RealSense device connected")
    if serial is not None and serial not in serials:
        raise InputError(f"no RealSense with serial {serial}; connected: {', '.join(serials)}")
    pipe, cfg = rs.pipeline(ctx), rs.config()
    if serial:
        cfg.enable_device(serial)
    cfg.enable_stream(rs.stream.depth, rs.format.z16, 30)
    profile = pipe.start(cfg)
    sensor = profile.get_device().first_depth_sensor()
    if actuator is not None and trigger is not None:
        kind, _, sync = parse_trigger(trigger)
        if kind == "realsense-emitter":
            actuator.attach(sensor)  # type: ignore[attr-defined]
        elif sync.rs_mode is not None and sensor.supports(rs.option.inter_cam_sync_mode):
            sensor.set_option(rs.option.inter_cam_sync_mode, sync.rs_mode)
    return pipe, profile


def _realsense_frames(pipe: Any, profile: Any, seconds: float) -> LiveFrames:
    rs = import_rs()
    scale = 1.0 / profile.get_device().first_depth_sensor().get_depth_scale()
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            ok, fs = pipe.try_wait_for_frames(200)
            if not ok:
                continue  # a triggered camera sends nothing outside its window
            d = fs.get_depth_frame()
            arrival = _arrival(d, rs)
            stamp = int(d.get_timestamp() * 1e6)
            yield (
                Frame(f"{d.get_frame_number():08d}", np.asanyarray(d.get_data()).copy(), stamp),
                scale,
                arrival,
            )
    finally:
        pipe.stop()


def _arrival(frame: Any, rs: Any) -> float:
    """When a frame reached the host, on ``time.monotonic``: the driver's time of arrival where the frame
    carries it (a loop that lags would otherwise stamp queued frames late and put them in later slots)."""
    toa = rs.frame_metadata_value.time_of_arrival
    now = time.monotonic()
    if frame.supports_frame_metadata(toa):
        return now - (time.time() - float(frame.get_frame_metadata(toa)) / 1000.0)
    return now


def _camera(
    camera: str, serial: str | None, seconds: float, actuator: Actuator | None, trigger: str | None
) -> LiveFrames:
    if camera == "realsense":
        return _realsense_frames(*_realsense(serial, actuator, trigger), seconds)
    from d2sr.triggers.orbbec import OrbbecActuator, open_orbbec, orbbec_frames

    triggered = isinstance(actuator, OrbbecActuator)
    device, pipe = open_orbbec(serial, triggered)
    if triggered:
        actuator.device = device  # type: ignore[union-attr]
    return orbbec_frames(pipe, seconds)


def run_live(
    backend: Backend,
    out: Path,
    source: str,
    trigger: str | None,
    controller: str,
    seconds: float,
    active_frames: int,
    repair: str,
    threshold: float | None,
    seed: int,
    on_result: Callable[[int, Result], None] | None = None,
    scene: bool = False,
) -> dict[str, Any]:
    """A live camera (``realsense[:SERIAL]`` or ``orbbec[:SERIAL]``) through one loop for ``seconds``;
    closed through ``trigger`` (a ``d2sr.triggers`` spec) when given; with ``scene``, a still camera's
    frames are also judged against its scene (``SensorLoop.scene``)."""
    camera, serial = check_camera(source, trigger)
    stats = RunStats()
    settings = {
        "source": source,
        "trigger": trigger,
        "controller": controller,
        "seconds": seconds,
        "scene": scene,
    }
    actuator = open_trigger(trigger, active_frames) if trigger is not None else None
    with contextlib.ExitStack() as stack:
        if actuator is not None:
            stack.callback(actuator.close)
        frames = _camera(camera, serial, seconds, actuator, trigger)
        folder = stack.enter_context(RunFolder(out, settings, resumable=False))
        ctrl = make_controller(controller, TOTAL_FRAMES, active_frames, seed=seed)
        loop = SensorLoop(backend, ctrl, None, folder.sink(0), threshold, repair, scene=scene)
        closed = ClosedLoop(loop, actuator) if actuator is not None else None
        for frame, scale, arrival in frames:
            cap = Capture(frame, scale)
            res = loop.process(cap) if closed is None else closed.process(cap, arrival)
            stats.add(res)
            if on_result is not None:
                on_result(0, res)
        summary = summarize(settings, [stats])
        folder.finish(summary)
    return summary
