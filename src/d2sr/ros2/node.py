"""The node: subscribe to a depth topic, run each frame through a ``d2sr.Pipeline`` (closed through a
trigger when given one), publish ``<topic>/repaired``, ``<topic>/mask`` and ``<topic>/status``."""

from __future__ import annotations

import contextlib
import os
import re
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from d2sr.errors import ConfigError, D2SRError, InputError
from d2sr.frames.base import MAX_PIXELS
from d2sr.frames.colour import decode_colour
from d2sr.runtime.stats import median_p99_ms
from d2sr.synth.gaps import ColourFrame, ColourGaps
from d2sr.synth.recording import confidence_image

__all__ = ["ENCODINGS", "QOS", "TRANSPORTS", "Ros2Node", "Stats", "Wire", "dds_topic", "domain_id"]

#: Depth encodings the node takes (REP 118: 16-bit in millimetres unless told, float in metres).
ENCODINGS: dict[str, np.dtype[Any]] = {
    "16UC1": np.dtype(np.uint16),
    "mono16": np.dtype(np.uint16),
    "32FC1": np.dtype(np.float32),
}
QOS = ("reliable", "best-effort")
#: How images travel (image_transport's names): raw ``sensor_msgs/Image``, or ``compressedDepth`` (a PNG in
#: a ``CompressedImage`` on ``<topic>/compressedDepth``, as orbbec_camera and realsense-ros publish it).
TRANSPORTS = ("raw", "compressedDepth")
#: QoS profiles by rclcpp's names (reliability, history depth). REP 2003: a driver publishes with the system
#: default, a subscriber takes sensor data (best effort, which matches reliable publishers too); Cyclone's
#: system default history is unbounded, so a depth is set.
PROFILES = {"SENSOR_DATA": (False, 5), "SYSTEM_DEFAULT": (True, 10), "DEFAULT": (True, 10)}
#: The node's streams, each overridable (``Wire.streams``): what it reads, then what it writes.
STREAMS_IN = ("depth", "info", "colour")
STREAMS_OUT = ("repaired", "mask", "status", "camera_info", "diagnostics", "confidence")
_NAME = re.compile(r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$")


def dds_topic(name: str) -> str:
    """ROS 2 topic ``/a/b`` (or ``a/b``) -> DDS topic ``rt/a/b``, or a ConfigError for a name ROS refuses."""
    if not _NAME.match(name):
        raise ConfigError(f"--topic: {name!r} is not a ROS 2 topic name (letters, digits, _ and /)")
    return "rt/" + name.lstrip("/")


def domain_id() -> int:
    """``ROS_DOMAIN_ID`` (0 when unset), as ROS 2 reads it."""
    raw = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
    if not raw.isdigit() or int(raw) > 232:
        raise ConfigError(f"ROS_DOMAIN_ID must be a number in 0..232, got {raw!r}")
    return int(raw)


LATENCY_WINDOW = 10_000  # frames whose latency the node's figures cover (about 5 min at 30 Hz)
# Frames taken but not yet started, at most: when the repair cannot keep up, the oldest of them is dropped
# (counted, said once) rather than queued, so a robot behind the node gets recent depth, not a growing lag.
WAITING = 2
DIAGNOSTICS_S = 1.0  # how often /diagnostics is written (ROS 2's diagnostic aggregator expects about 1 Hz)
MIN_SIDE = 8  # pixels: a smaller image is no depth frame the models can judge


@dataclass
class Stats:
    """What a node did: frames in, out, refused (malformed, or an encoding it does not take), dropped (not
    started when newer frames came and the repair was behind), flagged; seconds each of the last
    ``LATENCY_WINDOW`` frames spent in the node, from taken off the reader to its last message written (a
    fixed window: the node's memory stays flat however long it runs)."""

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


@dataclass(frozen=True)
class Wire:
    """How a node meets the DDS world: ``qos``, its publishers' reliability (the subscriber takes both
    kinds); ``domain`` (default ``ROS_DOMAIN_ID``); ``transport``, how images travel (``TRANSPORTS``);
    ``node_name`` and ``namespace``, as ROS 2's tools list the node; ``streams``, a stream's own QoS."""

    qos: str = "reliable"
    domain: int | None = None
    transport: str = "raw"
    node_name: str = "d2sr"
    namespace: str = "/"  # the node's; a relative topic name resolves under it, as in ROS 2
    streams: tuple[tuple[str, str], ...] = ()  # (stream, profile): a stream's own QoS (``PROFILES``)

    def profile(self, stream: str) -> tuple[bool, int]:
        """(reliable, history depth) of ``stream``: its own profile, else sensor data for what the node
        reads and ``qos`` for what it writes."""
        own = dict(self.streams).get(stream)
        if own is not None:
            return PROFILES[own]
        if stream in STREAMS_IN:
            return PROFILES["SENSOR_DATA"]
        return PROFILES["SYSTEM_DEFAULT" if self.qos == "reliable" else "SENSOR_DATA"]


class Ros2Node:
    """``topic``: the depth image topic; ``depth_scale``: units per metre of 16-bit images (default 1000,
    REP 118's millimetres); ``wire``: QoS, domain, transport and node name (``Wire``);
    ``pipeline``: keyword arguments of ``d2sr.Pipeline`` (controller, active_frames, trigger, model, ...);
    ``say``: where warnings go (one line each)."""

    def __init__(
        self,
        topic: str,
        depth_scale: float | None = None,
        wire: Wire | None = None,
        say: Callable[[str], None] | None = None,
        colour_topic: str | None = None,
        **pipeline: Any,
    ) -> None:
        w = wire if wire is not None else Wire()
        qos, domain, transport, node_name = w.qos, w.domain, w.transport, w.node_name
        if qos not in QOS:
            raise ConfigError(f"--qos must be one of {', '.join(QOS)}, got {qos!r}")
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", node_name):
            raise ConfigError(f"--node-name: {node_name!r} is not a ROS 2 node name (letters, digits and _)")
        for stream, profile in w.streams:
            if stream not in STREAMS_IN + STREAMS_OUT or profile not in PROFILES:
                raise ConfigError(f"{stream}_qos: {profile!r} is not one of {', '.join(PROFILES)}")
        if transport not in TRANSPORTS:
            raise ConfigError(f"--transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
        self.compressed = transport == "compressedDepth"
        if depth_scale is not None and not (
            isinstance(depth_scale, int | float) and np.isfinite(depth_scale) and depth_scale > 0
        ):
            raise ConfigError(
                f"--depth-scale must be a positive number of units per metre, got {depth_scale}"
            )
        if not w.namespace.startswith("/") or (w.namespace != "/" and not _NAME.match(w.namespace)):
            raise ConfigError(f"--namespace: {w.namespace!r} is not a ROS 2 namespace (/ or /a/b)")
        if not topic.startswith("/"):  # relative: under the node's namespace, as ROS 2 resolves it
            topic = w.namespace.rstrip("/") + "/" + topic
        self.topic = topic
        name = dds_topic(topic)
        self.namespace = w.namespace
        try:
            from cyclonedds.core import (
                InstanceState,
                Policy,
                Qos,
                ReadCondition,
                SampleState,
                ViewState,
                WaitSet,
            )
            from cyclonedds.domain import DomainParticipant
            from cyclonedds.pub import DataWriter
            from cyclonedds.sub import DataReader
            from cyclonedds.topic import Topic
            from cyclonedds.util import duration
        except ImportError:
            raise InputError("d2sr ros2 needs Cyclone DDS: pip install '.[ros2]'") from None
        from d2sr.ros2.msgs import CameraInfo, CompressedImage, DiagnosticArray, DiagnosticStatus, Image
        from d2sr.runtime.batch import repair_workers
        from d2sr.runtime.pipeline import Pipeline

        # Frames are judged in order and repaired on several threads (one onnxruntime thread each), as
        # d2sr recover does: on 2 cores that keeps 30 Hz where one frame at a time falls behind.
        workers, threads = repair_workers()
        self.pipeline = Pipeline(depth_scale, threads=threads, **pipeline)
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="d2sr-ros2")
        self._workers = workers
        self._running: deque[tuple[Any, float, Future[Any]]] = deque()
        self._waiting: deque[tuple[Any, float]] = deque()  # taken, not started (at most ``WAITING``)
        self._last_trouble = (0, 0)  # dropped and refused at the last /diagnostics
        self._warm_up()
        self.depth_scale = depth_scale
        self.say = say or (lambda line: None)
        self.stats = Stats()
        self._warned: set[str] = set()
        self.domain = domain_id() if domain is None else domain
        self.participant = _participant(DomainParticipant, self.domain)

        # A best-effort reader matches reliable and best-effort publishers alike.
        def qos_of(stream: str) -> Any:
            reliable, depth = w.profile(stream)
            how = (
                Policy.Reliability.Reliable(duration(milliseconds=100))
                if reliable
                else Policy.Reliability.BestEffort
            )
            return Qos(how, Policy.History.KeepLast(depth))

        if self.compressed:
            image_in = Topic(self.participant, f"{name}/compressedDepth", CompressedImage)
            self.repaired_compressed = DataWriter(
                self.participant,
                Topic(self.participant, f"{name}/repaired/compressedDepth", CompressedImage),
                qos=qos_of("repaired"),
            )
        else:
            image_in = Topic(self.participant, name, Image)
        self.reader = DataReader(self.participant, image_in, qos=qos_of("depth"))
        self.repaired = DataWriter(
            self.participant, Topic(self.participant, f"{name}/repaired", Image), qos=qos_of("repaired")
        )
        self.mask = DataWriter(
            self.participant, Topic(self.participant, f"{name}/mask", Image), qos=qos_of("mask")
        )
        self.status = DataWriter(
            self.participant,
            Topic(self.participant, f"{name}/status", DiagnosticStatus),
            qos=qos_of("status"),
        )
        # The camera's calibration, as image_transport pairs it: taken from beside the input image
        # (<namespace>/camera_info) and written beside the repaired one (T/camera_info) with its stamp.
        parent = self.topic.rsplit("/", 1)[0]
        info_in = Topic(self.participant, dds_topic(f"{parent}/camera_info"), CameraInfo)
        self.info_reader = DataReader(self.participant, info_in, qos=qos_of("info"))
        self.info = DataWriter(
            self.participant,
            Topic(self.participant, f"{name}/camera_info", CameraInfo),
            qos=qos_of("camera_info"),
        )
        self._info: Any = None  # the latest camera_info taken
        # Per camera, once a second: frames in and out, dropped, the interfered share, latency, the window.
        self.diagnostics = DataWriter(
            self.participant,
            Topic(self.participant, "rt/diagnostics", DiagnosticArray),
            qos=qos_of("diagnostics"),
        )
        self._next_diagnostics = time.monotonic() + DIAGNOSTICS_S
        self._waitset = WaitSet(self.participant)
        # Wake on data (a reader attached alone wakes only on its status changes).
        any_state = SampleState.Any | ViewState.Any | InstanceState.Any
        self._ready = [ReadCondition(self.reader, any_state)]
        # Colour, for the frames the laser skips: each colour frame with no depth frame of its stamp gets a
        # synthesized one (d2sr.synth), published on /repaired, marked in /status, with /confidence.
        self.colour_reader = None
        if colour_topic is not None:
            colour_in = Topic(self.participant, dds_topic(colour_topic), Image)
            self.colour_reader = DataReader(self.participant, colour_in, qos=qos_of("colour"))
            self._ready.append(ReadCondition(self.colour_reader, any_state))
            self.confidence = DataWriter(
                self.participant,
                Topic(self.participant, f"{name}/confidence", Image),
                qos=qos_of("confidence"),
            )
        for cond in self._ready:
            self._waitset.attach(cond)
        self._gaps = ColourGaps()  # which colour frames have no depth frame (extra: the message header)
        self._stop = threading.Event()
        self._duration = duration
        self._announce(node_name)

    def _announce(self, node_name: str) -> None:
        """Say on ``ros_discovery_info`` (transient local, as ROS 2's rmw does) that this participant holds
        the node ``/<node_name>`` with its readers and writers, so ``ros2 node list`` and ``ros2 node info``
        show it."""
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        from d2sr.ros2.msgs import NodeEntitiesInfo, ParticipantEntitiesInfo

        readers = [self.reader, self.info_reader, *([self.colour_reader] if self.colour_reader else [])]
        writers = [self.repaired, self.mask, self.status, self.info, self.diagnostics]
        writers += [
            w for w in (getattr(self, "repaired_compressed", None), getattr(self, "confidence", None)) if w
        ]
        node = NodeEntitiesInfo(
            self.namespace, node_name, [_gid(r.guid) for r in readers], [_gid(w.guid) for w in writers]
        )
        qos = Qos(Policy.Reliability.Reliable(self._duration(milliseconds=100)), Policy.History.KeepLast(1),
                  Policy.Durability.TransientLocal)  # fmt: skip
        topic = Topic(self.participant, "ros_discovery_info", ParticipantEntitiesInfo)
        self.graph = DataWriter(self.participant, topic, qos=qos)
        self.graph.write(ParticipantEntitiesInfo(_gid(self.participant.guid), [node]))
        self.node_name = node_name

    def stop(self) -> None:
        """Ask ``spin`` to return (safe from a signal handler or another thread)."""
        self._stop.set()

    def spin(self, seconds: float | None = None) -> Stats:
        """Take, repair and publish until ``stop`` (or for ``seconds``)."""
        if seconds is not None and not (np.isfinite(seconds) and seconds > 0):
            raise ConfigError(f"--seconds must be a positive number, got {seconds}")
        end = None if seconds is None else time.monotonic() + seconds
        while not self._stop.is_set() and (end is None or time.monotonic() < end):
            self._waitset.wait(self._duration(milliseconds=2 if self._running else 100))
            for sample in self.reader.take(N=64):
                if getattr(sample, "sample_info", None) is not None and not sample.sample_info.valid_data:
                    continue
                self.receive(sample, time.monotonic())
            self._take_info()
            if self.colour_reader is not None:
                for sample in self.colour_reader.take(N=8):
                    if getattr(sample, "sample_info", None) is None or sample.sample_info.valid_data:
                        self._colour(sample, time.monotonic())
            self._publish_done()
            self._start_waiting()
            self._synthesize_due(time.monotonic())
            if time.monotonic() >= self._next_diagnostics:
                self._next_diagnostics = time.monotonic() + DIAGNOSTICS_S
                self.diagnostics.write(self._diagnostics())
        while self._running or self._waiting:
            self._publish_done(wait=bool(self._running))
            self._start_waiting()
        return self.stats

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
        if i is None:
            return
        self.info.write(
            CameraInfo(header, i.height, i.width, i.distortion_model, list(i.d), list(i.k), list(i.r),
                       list(i.p), i.binning_x, i.binning_y, i.roi)
        )  # fmt: skip

    def receive(self, msg: Any, taken: float) -> None:
        """A message off the reader: it waits for a free worker; beyond ``WAITING`` such frames the oldest is
        dropped (counted in ``Stats.dropped`` and ``/status``, said once)."""
        self._waiting.append((msg, taken))
        while len(self._waiting) > WAITING:
            self._waiting.popleft()
            self.stats.received += 1
            self.stats.dropped += 1
            self._warn(f"{self.topic}: the repair is behind the frame rate; the oldest frames not started "
                       "are dropped (counted in /status as dropped)", "dropped")  # fmt: skip
        self._start_waiting()

    def _start_waiting(self) -> None:
        """Start waiting frames, oldest first, while a worker is free."""
        while self._waiting and len(self._running) < 2 * self._workers:
            msg, taken = self._waiting.popleft()
            self.handle(msg, taken)

    def close(self) -> None:
        self._pool.shutdown(wait=True)
        self.pipeline.close()
        for cond in self._ready:
            self._waitset.detach(cond)

    def handle(self, msg: Any, taken: float) -> None:
        """One image message: judged now, repaired on a worker, published in order once repaired. A message
        the node cannot use is dropped with a warning (once per kind) and the node keeps running."""
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
            self._publish_done(wait=True)
            self._synthesize(unjoined)
        try:
            decided = self.pipeline.decide(depth, stamp, arrival_s=taken)
        except D2SRError as exc:  # e.g. a --depth-scale given for a float topic: say so, keep running
            self._refuse(type(exc).__name__ + str(depth.shape), f"{self.topic}: {exc}; skipped")
            return
        except Exception as exc:  # a frame no check foresaw must not stop the node
            self._refuse(type(exc).__name__, f"{self.topic}: a frame failed ({type(exc).__name__}); skipped")
            return
        self._running.append((msg, taken, self._pool.submit(self.pipeline.finish, decided)))

    def _refuse(self, kind: str, line: str) -> None:
        self.stats.refused += 1
        self._warn(line, kind)

    def _publish_done(self, wait: bool = False) -> None:
        while self._running and (wait or self._running[0][2].done()):
            msg, taken, future = self._running.popleft()
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

    def _colour(self, msg: Any, taken: float) -> None:
        """A colour frame: kept for pairing with its depth frame, or for synthesis if none comes."""
        try:
            img = decode_colour(msg, "colour")
            stamp = _stamp(msg)
        except InputError as exc:
            self._warn(f"{exc}; such colour frames are skipped", "colour")
            return
        self._gaps.colour(ColourFrame(stamp, img, taken, msg.header))

    def _synthesize_due(self, now: float) -> None:
        """Colour frames that waited with no depth frame of their stamp: the laser skipped them."""
        self._synthesize(self._gaps.due(now))

    def _synthesize(self, colours: list[ColourFrame]) -> None:
        for c in colours:
            try:
                s = self.pipeline.synthesize(c.image)
            except InputError:
                continue  # no real frame yet
            self._publish_synthesized(c.extra, s, c.arrival)

    def _publish_synthesized(self, header: Any, s: Any, taken: float) -> None:
        from d2sr.ros2.msgs import Image

        out = np.ascontiguousarray(s.depth)
        h, w = out.shape
        enc = "32FC1" if out.dtype.kind == "f" else "16UC1"
        self.repaired.write(Image(header, h, w, enc, 0, w * out.itemsize, out.view(np.uint8).reshape(-1)))
        self.mask.write(Image(header, h, w, "mono8", 0, w, np.zeros(h * w, np.uint8)))
        self._write_info(header)
        conf = confidence_image(s.confidence)
        self.confidence.write(Image(header, h, w, "mono8", 0, w, conf.reshape(-1)))
        self.status.write(self._synth_status(header, s))
        self.stats.synthesized += 1

    def _synth_status(self, header: Any, s: Any) -> Any:
        from d2sr.ros2.msgs import DiagnosticStatus, KeyValue

        w = self.pipeline.window
        values = {
            "stamp": f"{header.stamp.sec}.{header.stamp.nanosec:09d}",
            "interfered": "false",
            "synthesized": "true",
            "method": s.method,
            "frames_since_real": str(s.since_real),
            "mean_confidence": f"{float(s.confidence.mean()):.3f}",
            "period": str(w.period),
            "window_offset": str(w.offset),
            "active_frames": str(w.active_frames),
            "total_frames": str(w.total_frames),
        }
        return DiagnosticStatus(
            0, "d2sr", "synthesized", self.topic, [KeyValue(k, v) for k, v in values.items()]
        )

    def _warm_up(self) -> None:
        """One frame through the models before the first message, so it pays no start-up cost."""
        net = self.pipeline.backend
        zeros = np.zeros((1, 480, 640), np.float32)
        net.scores(zeros, None)
        with contextlib.suppress(Exception):  # a detector-only setup (--repair none) has no recovery model
            net.recover(zeros, None)

    def _publish(self, msg: Any, taken: float, r: Any) -> None:
        from d2sr.ros2.msgs import Image

        out = np.ascontiguousarray(r.depth)
        h, w = out.shape
        encoding = msg.encoding if not self.compressed else "32FC1" if out.dtype.kind == "f" else "16UC1"
        self.repaired.write(
            Image(msg.header, h, w, encoding, 0, w * out.itemsize, out.view(np.uint8).reshape(-1))
        )
        if self.compressed:
            self.repaired_compressed.write(_compress(msg, out, r.mask))
        mask = np.where(r.mask, 255, 0).astype(np.uint8)
        self.mask.write(Image(msg.header, h, w, "mono8", 0, w, mask.reshape(-1)))
        self._write_info(msg.header)
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

    def _diagnostics(self) -> Any:
        """``/diagnostics``: this camera's status (WARN while frames are being dropped or refused)."""
        from d2sr.ros2.msgs import DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time

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
        status = DiagnosticStatus(1 if behind else 0, f"d2sr: {self.topic}", message, self.topic,
                                  [KeyValue(k, v) for k, v in values.items()])  # fmt: skip
        now = time.time_ns()
        return DiagnosticArray(Header(Time(now // 10**9, now % 10**9), ""), [status])

    def _status(self, msg: Any, r: Any, repaired: int) -> Any:
        from d2sr.ros2.msgs import DiagnosticStatus, KeyValue

        w = r.window
        values = {
            "stamp": f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}",
            "interfered": str(r.interfered).lower(),
            "score": f"{r.score:.4f}",
            "repaired_pixels": str(repaired),
            "synthesized": "false",
            "dropped": str(self.stats.dropped),
            "period": str(w.period),
            "window_offset": str(w.offset),
            "active_frames": str(w.active_frames),
            "total_frames": str(w.total_frames),
        }
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


_KINDS = 64  # kinds of warning a node remembers (and says once each)


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


def _gid(guid: Any) -> Any:
    """A DDS entity's GUID (a uuid.UUID) as ROS 2's graph id."""
    from d2sr.ros2.msgs import GID_BYTES, Gid

    raw = guid.bytes
    return Gid(list(raw) + [0] * (GID_BYTES - len(raw)))


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


def _participant(factory: Any, domain: int) -> Any:
    """A DDS participant, or one line when Cyclone refuses its configuration (``CYCLONEDDS_URI``): what
    Cyclone itself prints of it is caught and its first line said in ours."""
    import tempfile

    with tempfile.TemporaryFile() as caught:
        saved = os.dup(2)
        os.dup2(caught.fileno(), 2)
        try:
            return factory(domain)
        except Exception:
            pass
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        caught.seek(0)
        said = caught.read().decode("utf-8", "replace").strip().splitlines()
    why = said[0].split("config:", 1)[-1].strip()[:120] if said else "no reason given"
    uri = os.environ.get("CYCLONEDDS_URI", "")
    hint = f" (CYCLONEDDS_URI={uri[:60]!r})" if uri else ""
    raise ConfigError(f"Cyclone DDS could not start a participant in domain {domain}{hint}: {why}")
