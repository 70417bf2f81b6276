"""A live RealSense through pyrealsense2 (``pip install d2sr[realsense]``). Kept thin: the loop, output and
statistics are the tested ones; only the frame source and the trigger are here. Untested without hardware.

What the trigger needs: the controller's window must reach the laser. The L515 can be started per frame
through its external sync input (``inter_cam_sync_mode`` set to a slave mode, a pulse on the sync connector
per frame; about 60 ms start-up, 33 ms per frame, 110-122 ms from trigger to first frame). Driving that
line takes hardware on the host (a GPIO or a microcontroller): pass its ``Trigger`` to ``run_live``.
Without one the window is only logged, and the sensor keeps streaming (detection and repair still work).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import TOTAL_FRAMES, make_controller
from d2sr.errors import InputError
from d2sr.frames.base import Frame
from d2sr.frames.realsense import import_rs
from d2sr.runtime.backends import Backend
from d2sr.runtime.loop import Capture, Result, SensorLoop, Trigger
from d2sr.runtime.output import RunFolder
from d2sr.runtime.session import summarize
from d2sr.runtime.stats import RunStats

__all__ = ["live_frames", "run_live"]


def live_frames(serial: str | None, seconds: float) -> Iterator[tuple[Frame, float]]:
    """Depth frames (uint16) and the sensor's depth scale (units per metre) for ``seconds``."""
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
    try:
        scale = 1.0 / profile.get_device().first_depth_sensor().get_depth_scale()
        start = None
        while True:
            fs = pipe.wait_for_frames()
            d = fs.get_depth_frame()
            stamp = int(d.get_timestamp() * 1e6)
            start = stamp if start is None else start
            if (stamp - start) / 1e9 > seconds:
                return
            yield Frame(f"{d.get_frame_number():08d}", np.asanyarray(d.get_data()).copy(), stamp), scale
    finally:
        pipe.stop()


def run_live(
    backend: Backend,
    out: Path,
    controller: str,
    serial: str | None,
    seconds: float,
    active_frames: int,
    repair: str,
    threshold: float | None,
    seed: int,
    trigger: Trigger | None = None,
    on_result: Callable[[int, Result], None] | None = None,
) -> dict[str, Any]:
    """A live camera through one loop for ``seconds``; with a ``trigger``, closed loop."""
    stats = RunStats()
    settings = {"source": f"realsense:{serial or ''}", "controller": controller, "seconds": seconds}
    with RunFolder(out, settings, resumable=False) as folder:
        ctrl = make_controller(controller, TOTAL_FRAMES, active_frames, seed=seed)
        loop = SensorLoop(backend, ctrl, trigger, folder.sink(0), threshold, repair)
        for frame, scale in live_frames(serial, seconds):
            res = loop.process(Capture(frame, scale))
            stats.add(res)
            if on_result is not None:
                on_result(0, res)
        summary = summarize(settings, [stats])
        folder.finish(summary)
    return summary
