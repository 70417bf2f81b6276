"""What a live camera gives the loop: ``Shot``s, one per moment, in time order. A RealSense's depth and
colour for frame synthesis (``d2sr run realsense --fill``) stream from the two sensors on their own, not
through a pipeline: its syncer holds colour frames back while it waits for depth, then drops them (on a
software_device, the 8 colour frames after each window were lost). Here each depth frame is joined with the
colour frame of its stamp and aligned to it (librealsense's ``align``), and each colour frame no depth frame
joins comes alone: a moment the laser skipped."""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics
from d2sr.frames.realsense import import_rs
from d2sr.synth.gaps import PAIR_NS, WAIT_S, ColourFrame, ColourGaps

__all__ = ["Shot", "host_arrival", "rgbd_shots"]


@dataclass(frozen=True)
class Shot:
    """One moment from a camera: its depth frame (None: the laser was off), units per metre, when it reached
    the host (``time.monotonic``), and its colour image when colour is read (BGR, depth aligned to it)."""

    depth: Frame | None
    scale: float
    arrival: float
    colour: np.ndarray | None = None
    stamp: int = 0  # ns, the camera's clock


def host_arrival(frame: Any, rs: Any) -> float:
    """When a frame reached the host, on ``time.monotonic``: the driver's time of arrival where the frame
    carries it (a loop that lags would otherwise stamp queued frames late and put them in later slots)."""
    toa = rs.frame_metadata_value.time_of_arrival
    now = time.monotonic()
    if frame.supports_frame_metadata(toa):
        return now - (time.time() - float(frame.get_frame_metadata(toa)) / 1000.0)
    return now


def _profile(sensor: Any, fmt: Any, fps: int = 30) -> Any:
    """The sensor's stream profile of ``fmt`` at ``fps``: its default one if that matches, else the first."""
    found = [p for p in sensor.get_stream_profiles() if p.format() == fmt and p.fps() == fps]
    return next((p for p in found if p.is_default()), found[0] if found else None)


def rgbd_shots(depth_sensor: Any, colour_sensor: Any, seconds: float) -> tuple[Iterator[Shot], Intrinsics]:
    """Start both sensors (z16 and bgr8 at 30 fps) for ``seconds``: their shots, and the colour camera's
    intrinsics (the aligned depth's)."""
    rs = import_rs()
    dp, cp = _profile(depth_sensor, rs.format.z16), _profile(colour_sensor, rs.format.bgr8)
    if dp is None or cp is None:
        raise InputError("this RealSense streams no z16 depth and bgr8 colour at 30 fps")
    i = cp.as_video_stream_profile().get_intrinsics()
    intrinsics = Intrinsics(i.width, i.height, i.fx, i.fy, i.ppx, i.ppy)
    queue = rs.frame_queue(64, True)  # both streams in arrival order, frames kept past the callback
    depth_sensor.open(dp)
    colour_sensor.open(cp)
    depth_sensor.start(queue)
    colour_sensor.start(queue)
    return _Joiner(rs, queue, 1.0 / depth_sensor.get_depth_scale()).shots(
        seconds, (depth_sensor, colour_sensor)
    ), intrinsics


class _Joiner:
    """Depth frames joined with their colour frames and aligned; colour frames alone where none joins."""

    def __init__(self, rs: Any, queue: Any, scale: float) -> None:
        self.rs, self.queue, self.scale = rs, queue, scale
        self.align = rs.align(rs.stream.color)  # depth onto the colour camera's pixels
        self._pair: list[Any] = []
        # align takes a frameset: one made of the pair by a processing block
        self._composer = rs.processing_block(
            lambda f, src: src.frame_ready(src.allocate_composite_frame(self._pair))
        )
        self._composed = rs.frame_queue(2, True)
        self._composer.start(self._composed)
        self.gaps = ColourGaps()

    def shots(self, seconds: float, sensors: tuple[Any, ...]) -> Iterator[Shot]:
        rs, gaps = self.rs, self.gaps
        end = time.monotonic() + seconds
        waiting: Any = None  # a depth frame waiting for its colour frame
        until = 0.0
        try:
            while time.monotonic() < end:
                ok, f = self.queue.try_wait_for_frame(20)
                now = time.monotonic()
                if ok and f.get_profile().stream_type() == rs.stream.color:
                    img = np.asanyarray(f.get_data()).copy()
                    gaps.colour(ColourFrame(_ns(f), img, host_arrival(f, rs), f))
                elif ok and f.is_depth_frame():
                    if waiting is not None:  # a newer depth frame came first: the older goes as it is
                        yield self._real(waiting)
                    yield from self._alone(gaps.depth(_ns(f)))
                    waiting, until = f, now + WAIT_S
                # Waits end only once the queue is empty: a loaded host reads frames late, not never.
                if waiting is not None:
                    newest = gaps.newest()
                    passed = newest is not None and newest > _ns(waiting) + PAIR_NS
                    if gaps.joined(_ns(waiting)) is not None or passed or (now >= until and not ok):
                        yield self._real(waiting)
                        waiting = None
                if waiting is None and not ok:
                    yield from self._alone(gaps.due(now))
            if waiting is not None:
                yield self._real(waiting)
            yield from self._alone(gaps.flush())
        finally:
            for s in sensors:
                s.stop()
                s.close()

    def _alone(self, colours: list[ColourFrame]) -> Iterator[Shot]:
        for c in colours:
            yield Shot(None, self.scale, c.arrival, c.image, c.stamp)

    def _real(self, d: Any) -> Shot:
        stamp, arrival = _ns(d), host_arrival(d, self.rs)
        c = self.gaps.joined(stamp)
        self.gaps.real(stamp)
        if c is not None:
            self._pair[:] = [d, c.extra]
            self._composer.invoke(d)
            fs = self._composed.wait_for_frame(1000).as_frameset()
            d = self.align.process(fs).get_depth_frame()
        depth = np.asanyarray(d.get_data()).copy()
        name = f"{d.get_frame_number():08d}"
        return Shot(Frame(name, depth, stamp), self.scale, arrival, None if c is None else c.image, stamp)


def _ns(frame: Any) -> int:
    return int(frame.get_timestamp() * 1e6)
