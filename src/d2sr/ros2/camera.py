"""One camera of a node: its topics, its ``d2sr.Pipeline`` (the models are shared between cameras), the
frames it has taken and not yet published, and what it says about them (``/status``, its part of
``/diagnostics``)."""

from __future__ import annotations

import contextlib
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Executor, Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import D2SRError, InputError
from d2sr.frames.base import MAX_PIXELS
from d2sr.frames.colour import decode_colour
from d2sr.jobs.stats import median_p99_ms
from d2sr.ros2.dds import Dds
from d2sr.ros2.wire import Wire
from d2sr.runtime.pipeline import Pipeline
from d2sr.synth.gaps import ColourFrame, ColourGaps
from d2sr.synth.recording import confidence_image

__all__ = ["ENCODINGS", "Camera", "CameraLoop", "Stats", "planned"]

#: Depth encodings the node takes (REP 118: 16-bit in millimetres unless told, float in metres).
ENCODINGS: dict[str, np.dtype[Any]] = {
    "16UC1": np.dtype(np.uint16),
    "mono16": np.dtype(np.uint16),
    "32FC1": np.dtype(np.float32),
}
LATENCY_WINDOW = 10_000  # frames whose latency the node's figures cover (about 5 min at 30 Hz)
# Frames taken but not yet started, at most, per camera: when the repair cannot keep up, the oldest of them
# is dropped (counted, said once) rather than queued, so a robot behind the node gets recent depth, not a
# growing lag.
WAITING = 2
MIN_SIDE = 8  # pixels: a smaller image is no depth frame the models can judge
_KINDS = 64  # kinds of warning a camera remembers (and says once each)


@dataclass(frozen=True)
class Camera:
    """One camera a node repairs: its depth ``topic`` (relative: under the node's namespace); with
    ``colour_topic``, frames its laser skipped are synthesized from colour; ``trigger`` and ``scene_from``:
    its own trigger line and stored scene (a ``d2sr.Pipeline``'s), over the node's."""

    topic: str
    colour_topic: str | None = None
    trigger: str | None = None
    scene_from: Path | None = None


def planned(camera: Camera, wire: Wire) -> tuple[list[str], list[str]]:
    """(what a camera's loop reads, what it writes): ROS 2 names, resolved and remapped, as ``CameraLoop``
    names its readers and writers (``_names``). A name ROS 2 or DDS refuses is a ConfigError here."""
    ins, outs = _names(wire.resolve(camera.topic), camera, wire.transport == "compressedDepth")
    return [wire.resolve(n) for n in ins.values()], [wire.resolve(n) for n in outs.values()]


def _names(t: str, camera: Camera, compressed: bool) -> tuple[dict[str, str], dict[str, str]]:
    """(stream -> name read, stream -> name written) of the camera whose depth topic resolves to ``t``."""
    # The camera's calibration, as image_transport pairs it: taken from beside the input image
    # (<namespace>/camera_info) and written beside the repaired one (T/camera_info) with its stamp.
    ins = {"depth": f"{t}/compressedDepth" if compressed else t, "info": t.rsplit("/", 1)[0] + "/camera_info"}
    outs = {
        "repaired": f"{t}/repaired",
        "mask": f"{t}/mask",
        "status": f"{t}/status",
        "camera_info": f"{t}/camera_info",
    }
    if compressed:
        outs["repaired_compressed"] = f"{t}/repaired/compressedDepth"
    if camera.colour_topic is not None:
        ins["colour"] = camera.colour_topic
        outs["confidence"] = f"{t}/confidence"
    return ins, outs


@dataclass
class Stats:
    """What a camera's loop did: frames in, out, refused (malformed, or an encoding it does not take),
    dropped (not started when newer frames came and the repair was behind), flagged; seconds each of the
    last ``LATENCY_WINDOW`` frames spent in the node, from taken off the reader to its last message written
    (a fixed window: the node's memory stays flat however long it runs)."""

    received: int = 0
    published: int = 0
    refused: int = 0
    dropped: int = 0
    flagged: int = 0
    synthesized: int = 0
    seconds: deque[float] = field(default_factory=lambda: deque(maxlen=LATENCY_WINDOW))

    def latency_ms(self) -> dict[str, float]:
        median, p99 = median_p99_ms(list(self.seconds))
        return {"median": median, "p99": p99}


class CameraLoop:
    """``camera``'s readers, writers and loop on ``dds``: frames are judged in order on the node's thread
    (``handle``), repaired on ``pool``, published in order (``publish_done``)."""

    def __init__(
        self, camera: Camera, pipeline: Pipeline, dds: Dds, pool: Executor, say: Callable[[str], None]
    ) -> None:
        from d2sr.ros2.msgs import CameraInfo, CompressedImage, DiagnosticStatus, Image

        self.camera, self.pipeline, self.pool, self.say = camera, pipeline, pool, say
        self.compressed = dds.wire.transport == "compressedDepth"
        t = self.topic = dds.wire.resolve(camera.topic)  # as named in logs and /status
        ins, outs = _names(t, camera, self.compressed)
        if self.compressed:
            self.reader = dds.reader(ins["depth"], CompressedImage, "depth")
            self.repaired_compressed = dds.writer(outs["repaired_compressed"], CompressedImage, "repaired")
        else:
            self.reader = dds.reader(ins["depth"], Image, "depth")
        self.repaired = dds.writer(outs["repaired"], Image, "repaired")
        self.mask = dds.writer(outs["mask"], Image, "mask")
        self.status = dds.writer(outs["status"], DiagnosticStatus, "status")
        self.info_reader = dds.reader(ins["info"], CameraInfo, "info")
        self.info = dds.writer(outs["camera_info"], CameraInfo, "camera_info")
        self._info: Any = None  # the latest camera_info taken
        # Colour, for the frames the laser skips: each colour frame with no depth frame of its stamp gets a
        # synthesized one (d2sr.synth), published on /repaired, marked in /status, with /confidence.
        self.colour_reader = None
        if camera.colour_topic is not None:
            self.colour_reader = dds.reader(ins["colour"], Image, "colour")
            self.confidence = dds.writer(outs["confidence"], Image, "confidence")
        self.stats = Stats()
        self.running: deque[tuple[Any, float, Future[Any]]] = deque()
        self.waiting: deque[tuple[Any, float]] = deque()  # taken, not started (at most ``WAITING``)
        self._gaps = ColourGaps()  # which colour frames have no depth frame (extra: the message header)
        self._warned: set[str] = set()
        self._last_trouble = (0, 0)  # dropped and refused at the last /diagnostics

    @property
    def outputs(self) -> list[str]:
        """The ROS 2 names of ``/repaired``, ``/mask`` and ``/status`` (after remapping)."""
        return [w.topic.name.removeprefix("rt") for w in (self.repaired, self.mask, self.status)]

    @property
    def readers(self) -> list[Any]:
        return [*self.waking, self.info_reader]

    @property
    def waking(self) -> list[Any]:
        """The readers whose data wakes the node (camera_info is only kept, taken with the next frame)."""
        return [self.reader, *([self.colour_reader] if self.colour_reader else [])]

    @property
    def writers(self) -> list[Any]:
        own = [getattr(self, "repaired_compressed", None), getattr(self, "confidence", None)]
        return [self.repaired, self.mask, self.status, self.info, *(w for w in own if w is not None)]

    def take(self, now: Callable[[], float]) -> None:
        """Whatever its readers hold: depth frames wait (``receive``), camera_info and colour are kept. A
        message that cannot be decoded is refused here (counted, said once) and the rest are taken."""
        from d2sr.ros2.msgs import unreadable

        for sample in self._taken(self.reader, 64):
            why = unreadable(sample)
            if why is not None:
                self.stats.received += 1
                self._refuse("undecodable", f"{self.topic}: a message is not a readable image ({why}); "
                             "such messages are skipped")  # fmt: skip
                continue
            self.receive(sample, now())
        self._take_info()
        if self.colour_reader is not None:
            for sample in self._taken(self.colour_reader, 8):
                if unreadable(sample) is None:
                    self._colour(sample, now())
                else:
                    self._warn(f"{self.topic}: a colour message is not a readable image; skipped", "colour")

    def _taken(self, reader: Any, n: int) -> list[Any]:
        """The valid samples a reader holds, at most ``n``; none (said once) when the take itself fails."""
        try:
            samples = reader.take(N=n)
        except Exception as exc:  # what Cyclone could not hand over must not stop the node
            self._warn(f"{self.topic}: a take failed ({type(exc).__name__}); its messages are lost", "take")
            return []
        return [s for s in samples if getattr(s, "sample_info", None) is None or s.sample_info.valid_data]

    def receive(self, msg: Any, taken: float) -> None:
        """A message off the reader: it waits for a free worker; beyond ``WAITING`` such frames the oldest is
        dropped (counted in ``Stats.dropped`` and ``/status``, said once)."""
        self.waiting.append((msg, taken))
        if self.colour_reader is not None:
            with contextlib.suppress(InputError):  # a bad stamp is refused when handled
                self._gaps.coming(_stamp(msg))  # its colour frame must not come due while this one waits
        while len(self.waiting) > WAITING:
            self.waiting.popleft()
            self.stats.received += 1
            self.stats.dropped += 1
            self._warn(f"{self.topic}: the repair is behind the frame rate; the oldest frames not started "
                       "are dropped (counted in /status as dropped)", "dropped")  # fmt: skip

    def start_oldest(self) -> None:
        """Start the oldest waiting frame."""
        msg, taken = self.waiting.popleft()
        self.handle(msg, taken)

    def handle(self, msg: Any, taken: float) -> None:
        """One image message: judged now, repaired on a worker, published in order once repaired. A message
        the camera cannot use is dropped with a warning (once per kind) and the node keeps running."""
        self.stats.received += 1
        try:
            depth = self._depth(msg)
            stamp = _stamp(msg)
        except InputError as exc:
            self._refuse("malformed", f"{self.topic}: {exc}; such messages are skipped")
            return
        if depth is None:
            self.stats.refused += 1
            return
        unjoined = self._gaps.depth(stamp)
        if unjoined:  # the slots before this window: made from the last real frame, before this one is
            self.publish_done(wait=True)
            self._synthesize(unjoined)
        try:
            decided = self.pipeline.decide(depth, stamp, arrival_s=taken)
        except D2SRError as exc:  # e.g. a --depth-scale given for a float topic: say so, keep running
            self._refuse(type(exc).__name__ + str(depth.shape), f"{self.topic}: {exc}; skipped")
            return
        except Exception as exc:  # a frame no check foresaw must not stop the node
            self._refuse(type(exc).__name__, f"{self.topic}: a frame failed ({type(exc).__name__}); skipped")
            return
        self.running.append((msg, taken, self.pool.submit(self.pipeline.finish, decided)))

    def publish_done(self, wait: bool = False) -> None:
        """Publish the repaired frames at the head of the line (``wait``: the first even if not yet done)."""
        while self.running and (wait or self.running[0][2].done()):
            msg, taken, future = self.running.popleft()
            try:
                r = future.result()
            except Exception as exc:  # a repair that failed drops its frame, not the node
                self._refuse(
                    type(exc).__name__, f"{self.topic}: a repair failed ({type(exc).__name__}); skipped"
                )
                continue
            self._publish(msg, taken, r)
            if self.colour_reader is not None:
                stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                self.pipeline.keep(r, self._gaps.colour_at(stamp))
                self._gaps.real(stamp)
            wait = False

    def synthesize_due(self, now: float) -> None:
        """Colour frames that waited with no depth frame of their stamp: the laser skipped them."""
        self._synthesize(self._gaps.due(now))

    def diagnostic(self) -> Any:
        """This camera's ``DiagnosticStatus`` for ``/diagnostics`` (WARN while frames are dropped or
        refused)."""
        from d2sr.ros2.msgs import DiagnosticStatus, KeyValue

        st, w = self.stats, self.pipeline.window
        lat = st.latency_ms() if st.published else {"median": float("nan"), "p99": float("nan")}
        values = {
            "frames_in": str(st.received),
            "frames_out": str(st.published),
            "dropped": str(st.dropped),
            "refused": str(st.refused),
            "synthesized": str(st.synthesized),
            "interfered_share": f"{st.flagged / st.published:.4f}" if st.published else "n/a",
            "latency_median_ms": f"{lat['median']:.1f}" if st.published else "n/a",
            "latency_p99_ms": f"{lat['p99']:.1f}" if st.published else "n/a",
            "period": str(w.period),
            "window_offset": str(w.offset),
            "active_frames": str(w.active_frames),
            "total_frames": str(w.total_frames),
        }
        behind = (st.dropped, st.refused) != self._last_trouble
        self._last_trouble = (st.dropped, st.refused)
        message = "dropping or refusing frames" if behind else "ok"
        return DiagnosticStatus(1 if behind else 0, f"d2sr: {self.topic}", message, self.topic,
                                [KeyValue(k, v) for k, v in values.items()])  # fmt: skip

    def _take_info(self) -> None:
        """Keep the latest camera_info (a malformed one is skipped with a warning, once)."""
        try:
            for sample in self.info_reader.take(N=8):
                info = getattr(sample, "sample_info", None)
                if info is None or info.valid_data:
                    self._info = sample
        except Exception as exc:  # a message Cyclone cannot decode must not stop the node
            self._warn(
                f"{self.topic}: a camera_info could not be read ({type(exc).__name__}); skipped", "info"
            )

    def _write_info(self, header: Any) -> None:
        """The latest camera_info again, beside the repaired frame, with that frame's header (stamp)."""
        from d2sr.ros2.msgs import CameraInfo

        i = self._info
        if i is None or not _read(self.info):
            return
        self.info.write(
            CameraInfo(header, i.height, i.width, i.distortion_model, list(i.d), list(i.k), list(i.r),
                       list(i.p), i.binning_x, i.binning_y, i.roi)
        )  # fmt: skip

    def _refuse(self, kind: str, line: str) -> None:
        self.stats.refused += 1
        self._warn(line, kind)

    def _colour(self, msg: Any, taken: float) -> None:
        """A colour frame: kept for pairing with its depth frame, or for synthesis if none comes."""
        try:
            img = decode_colour(msg, "colour")
            stamp = _stamp(msg)
        except InputError as exc:
            self._warn(f"{exc}; such colour frames are skipped", "colour")
            return
        self._gaps.colour(ColourFrame(stamp, img, taken, msg.header))

    def _synthesize(self, colours: list[ColourFrame]) -> None:
        for c in colours:
            try:
                s = self.pipeline.synthesize(c.image)
            except InputError:
                continue  # no real frame yet
            self._publish_synthesized(c.extra, s)

    def _publish_synthesized(self, header: Any, s: Any) -> None:
        from d2sr.ros2.msgs import Image

        out = np.ascontiguousarray(s.depth)
        h, w = out.shape
        enc = "32FC1" if out.dtype.kind == "f" else "16UC1"
        self.repaired.write(Image(header, h, w, enc, 0, w * out.itemsize, out.view(np.uint8).reshape(-1)))
        if _read(self.mask):
            self.mask.write(Image(header, h, w, "mono8", 0, w, np.zeros(h * w, np.uint8)))
        self._write_info(header)
        if _read(self.confidence):
            conf = confidence_image(s.confidence)
            self.confidence.write(Image(header, h, w, "mono8", 0, w, conf.reshape(-1)))
        if _read(self.status):
            self.status.write(self._synth_status(header, s))
        self.stats.synthesized += 1

    def _window_values(self, w: Any) -> dict[str, str]:
        return {
            "period": str(w.period),
            "window_offset": str(w.offset),
            "active_frames": str(w.active_frames),
            "total_frames": str(w.total_frames),
        }

    def _synth_status(self, header: Any, s: Any) -> Any:
        from d2sr.ros2.msgs import DiagnosticStatus, KeyValue

        values = {
            "stamp": f"{header.stamp.sec}.{header.stamp.nanosec:09d}",
            "interfered": "false",
            "synthesized": "true",
            "method": s.method,
            "frames_since_real": str(s.since_real),
            "mean_confidence": f"{float(s.confidence.mean()):.3f}",
        } | self._window_values(self.pipeline.window)
        return DiagnosticStatus(
            0, "d2sr", "synthesized", self.topic, [KeyValue(k, v) for k, v in values.items()]
        )

    def _publish(self, msg: Any, taken: float, r: Any) -> None:
        from d2sr.ros2.msgs import Image

        out = np.ascontiguousarray(r.depth)
        h, w = out.shape
        encoding = msg.encoding if not self.compressed else "32FC1" if out.dtype.kind == "f" else "16UC1"
        self.repaired.write(
            Image(msg.header, h, w, encoding, 0, w * out.itemsize, out.view(np.uint8).reshape(-1))
        )
        if self.compressed and _read(self.repaired_compressed):
            self.repaired_compressed.write(_compress(msg, out, r.mask))
        if _read(self.mask):
            mask = np.where(r.mask, 255, 0).astype(np.uint8)
            self.mask.write(Image(msg.header, h, w, "mono8", 0, w, mask.reshape(-1)))
        self._write_info(msg.header)
        if _read(self.status):
            self.status.write(self._status(msg, r, int(r.mask.sum())))
        self.stats.published += 1
        self.stats.flagged += r.interfered
        self.stats.seconds.append(time.monotonic() - taken)

    def _depth(self, msg: Any) -> np.ndarray | None:
        """The message's depth image, or None (with a warning once per kind) for one the node does not take;
        sizes are checked before any array is made."""
        if self.compressed:
            from d2sr.frames.rosbag import decode_image
            from d2sr.ros2.msgs import COMPRESSED

            return decode_image(msg, COMPRESSED, f"{self.topic}/compressedDepth")[0]
        dtype = ENCODINGS.get(msg.encoding) if isinstance(msg.encoding, str) else None
        if dtype is None:
            self._warn(f"{self.topic}: encoding {str(msg.encoding)[:40]!r} is not a depth image d2sr takes "
                       f"({', '.join(ENCODINGS)}); those messages are skipped", "encoding")  # fmt: skip
            return None
        h, w, step = int(msg.height), int(msg.width), int(msg.step)
        if min(h, w) < MIN_SIDE or h * w > MAX_PIXELS:
            self._warn(f"{self.topic}: an image of {w}x{h} pixels (d2sr takes {MIN_SIDE}x{MIN_SIDE} up to "
                       f"{MAX_PIXELS // 10**6} MP); such messages are skipped", "size")  # fmt: skip
            return None
        row = w * dtype.itemsize
        if step < row or len(msg.data) < step * h or step > 16 * row:
            self._warn(
                f"{self.topic}: an image's size, step and data disagree; such messages are skipped", "step"
            )
            return None
        data = np.frombuffer(_bytes(msg.data, step * h), np.uint8)
        rows = data.reshape(h, step)[:, :row]
        depth = np.ascontiguousarray(rows).view(dtype.newbyteorder(">" if msg.is_bigendian else "<"))
        return depth.astype(dtype, copy=False)

    def _status(self, msg: Any, r: Any, repaired: int) -> Any:
        from d2sr.ros2.msgs import DiagnosticStatus, KeyValue

        values = {
            "stamp": f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}",
            "interfered": str(r.interfered).lower(),
            "score": f"{r.score:.4f}",
            "repaired_pixels": str(repaired),
            "synthesized": "false",
            "dropped": str(self.stats.dropped),
        } | self._window_values(r.window)
        return DiagnosticStatus(
            1 if r.interfered else 0,
            "d2sr",
            "interfered" if r.interfered else "clean",
            self.topic,
            [KeyValue(k, v) for k, v in values.items()],
        )

    def _warn(self, line: str, kind: str | None = None) -> None:
        """Say ``line`` once per ``kind`` (the line itself by default); at most ``_KINDS`` kinds are kept."""
        key = kind or line
        if key not in self._warned and len(self._warned) < _KINDS:
            self._warned.add(key)
            self.say(line)


def _compress(msg: Any, depth: np.ndarray, mask: np.ndarray) -> Any:
    """The repaired frame as ``msg`` came (compressedDepth: its 12-byte header, then a PNG): the input's
    quantized pixels with the repaired ones written in, so every other pixel is as it was."""
    from d2sr.frames.png import decode_png, encode_png
    from d2sr.frames.rosbag import _HEADER
    from d2sr.ros2.msgs import CompressedImage

    raw = bytes(msg.data)
    head = raw[: _HEADER.size]
    if str(msg.format).startswith("32FC1"):  # inverse depth, quantized: img = a / depth + b
        img = decode_png(raw[_HEADER.size :], "compressedDepth")
        _, a, b = _HEADER.unpack(head)
        d = np.maximum(depth[mask].astype(np.float64), 1e-6)
        img[mask] = np.where(depth[mask] > 0, np.clip(np.rint(a / d + b), 1, 65535), 0).astype(np.uint16)
    else:  # millimetres: the repaired frame is the input's pixels bit for bit outside the mask
        img = depth
    data = np.frombuffer(head + encode_png(img, "compressedDepth"), np.uint8)
    return CompressedImage(msg.header, str(msg.format), data)


def _read(writer: Any) -> bool:
    """Someone subscribes to ``writer``'s topic. A stream nobody reads is not made, as image_transport's
    publishers skip theirs: making and writing a frame's mask costs the loop time even with no reader. DDS
    delivers only to readers a writer has matched, so nothing a reader could get is
    skipped."""
    return bool(writer.get_matched_subscriptions())


def _stamp(msg: Any) -> int:
    try:
        sec, nsec = int(msg.header.stamp.sec), int(msg.header.stamp.nanosec)
    except (AttributeError, TypeError, ValueError):
        raise InputError("a message without a usable header stamp") from None
    return sec * 10**9 + nsec


def _bytes(data: Any, n: int) -> bytes | memoryview:
    """The first ``n`` bytes of a message's data (bytes, a bytearray or a list of ints)."""
    if isinstance(data, bytes | bytearray | memoryview):
        return memoryview(data)[:n]
    return bytes(data[:n])
