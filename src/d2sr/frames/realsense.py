"""RealSense recordings (``.db3`` from librealsense >= 2.56, ``.bag`` from older ones) through
pyrealsense2 playback. Optional: ``pip install '.[realsense]'`` (needs libusb-1.0 on Linux)."""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics, Reader, Writer

__all__ = ["RealSenseReader", "RealSenseWriter", "import_rs"]


def _preload_libusb() -> None:
    """pyrealsense2's wheel links libusb-1.0 without shipping it; libusb-package ships one. Load it
    (globally) first so that a fresh pip install works without a system package."""
    try:
        import libusb_package
    except ImportError:
        return
    path = libusb_package.get_library_path()
    if path is not None:
        ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)


def import_rs() -> Any:
    try:
        _preload_libusb()
        import pyrealsense2 as rs
    except (ImportError, OSError) as exc:
        hint = " (install libusb-1.0-0 or libusb-package)" if "libusb" in str(exc) else ""
        raise InputError(
            f"RealSense recordings need pyrealsense2: pip install '.[realsense]'{hint}"
        ) from None
    return rs


class RealSenseReader(Reader):
    """The depth stream of a RealSense recording, played back as fast as it is read."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.rs = import_rs()
        with self._device() as (_, sensor, profile):
            units = (
                sensor.get_option(self.rs.option.depth_units)
                if sensor.supports(self.rs.option.depth_units)
                else 0.001
            )
            self.depth_scale = round(1.0 / units, 3)
            i = profile.as_video_stream_profile().get_intrinsics()
            self.intrinsics = Intrinsics(i.width, i.height, i.fx, i.fy, i.ppx, i.ppy)
        self._count: int | None = None

    @contextlib.contextmanager
    def _device(self) -> Iterator[tuple[Any, Any, Any]]:  # pyrealsense2 objects (untyped)
        rs = self.rs
        try:
            dev = rs.context().load_device(str(self.path))
        except RuntimeError as exc:
            raise InputError(f"{self.path}: not a readable RealSense recording: {exc}") from None
        pb = dev.as_playback()
        pb.set_real_time(False)
        for sensor in dev.query_sensors():
            for p in sensor.get_stream_profiles():
                if p.stream_type() == rs.stream.depth and p.format() == rs.format.z16:
                    yield pb, sensor, p
                    return
        raise InputError(f"{self.path}: RealSense recording has no z16 depth stream")

    def __iter__(self) -> Iterator[Frame]:
        rs = self.rs
        with self._device() as (pb, sensor, profile):
            queue = rs.frame_queue(64, True)
            sensor.open(profile)
            sensor.start(queue)
            try:
                i = 0
                while True:
                    ok, fr = queue.try_wait_for_frame(200)
                    if not ok:
                        if pb.current_status() == rs.playback_status.stopped:
                            break
                        continue
                    depth = np.asanyarray(fr.get_data()).copy()
                    # Timestamps are milliseconds in a double: microseconds survive, nanoseconds do not.
                    ns = round(fr.get_timestamp() * 1000) * 1000
                    yield Frame(f"{i:06d}", depth, ns, {"frame_number": fr.get_frame_number()})
                    i += 1
                self._count = i
            finally:
                with contextlib.suppress(RuntimeError):
                    sensor.stop()
                    sensor.close()

    def __len__(self) -> int:
        if self._count is None:
            self._count = sum(1 for _ in self)
        return self._count

    @property
    def shape(self) -> tuple[int, int] | None:
        return None if self.intrinsics is None else (self.intrinsics.height, self.intrinsics.width)


class RealSenseWriter(Writer):
    """Records frames with librealsense's own recorder through a software device (no camera needed)."""

    def __init__(
        self, path: Path, depth_scale: float, intrinsics: Intrinsics | None = None, fps: int = 30
    ) -> None:
        if Path(path).suffix != ".db3":
            raise InputError(f"{path}: RealSense recordings are written as .db3")
        super().__init__(path, depth_scale, intrinsics)
        self.rs = import_rs()
        self.fps = fps
        self._sensor: Any = None

    def _start(self, h: int, w: int) -> None:
        rs = self.rs
        assert self._tmp is not None
        self._tmp.unlink()  # the recorder creates the file itself
        self._dev = rs.software_device()
        sensor = self._dev.add_sensor("Depth")
        ii = self.intrinsics or Intrinsics(w, h, w / 1.4, w / 1.4, w / 2, h / 2)
        intr = rs.intrinsics()
        intr.width, intr.height, intr.fx, intr.fy, intr.ppx, intr.ppy = w, h, ii.fx, ii.fy, ii.px, ii.py
        intr.model, intr.coeffs = rs.distortion.none, [0.0] * 5
        vs = rs.video_stream()
        vs.type, vs.index, vs.uid, vs.width, vs.height = rs.stream.depth, 0, 0, w, h
        vs.fps, vs.bpp, vs.fmt, vs.intrinsics = self.fps, 2, rs.format.z16, intr
        self._profile = sensor.add_video_stream(vs)
        sensor.add_read_only_option(rs.option.depth_units, 1.0 / self.depth_scale)
        self._recorder = rs.recorder(str(self._tmp), self._dev)
        self._queue = rs.frame_queue(4, True)
        sensor.open(self._profile)
        sensor.start(self._queue)
        self._sensor = sensor

    def _write(self, frame: Frame) -> None:
        if frame.depth.dtype != np.uint16:
            raise InputError(
                f"{self.path}: RealSense depth is uint16 (z16); frame {frame.name} is {frame.depth.dtype}"
            )
        h, w = frame.depth.shape
        if self._sensor is None:
            self._start(h, w)
        rs = self.rs
        f = rs.software_video_frame()
        f.pixels, f.stride, f.bpp = np.ascontiguousarray(frame.depth), 2 * w, 2
        f.timestamp = (frame.timestamp_ns or 0) / 1e6
        f.domain, f.frame_number = rs.timestamp_domain.system_time, self.count
        f.profile = self._profile.as_video_stream_profile()
        self._sensor.on_video_frame(f)
        self._queue.wait_for_frame()

    def _stop(self) -> None:
        if self._sensor is not None:
            self._sensor.stop()
            self._sensor.close()
            del self._recorder  # the recorder writes its index when released
            self._sensor = None

    def _finish(self) -> None:
        if self._sensor is None:
            raise InputError(f"{self.path}: no frames to write")
        self._stop()

    def abort(self) -> None:
        with contextlib.suppress(RuntimeError):
            self._stop()
        super().abort()
