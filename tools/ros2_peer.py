"""A ROS 2 peer of ``d2sr ros2`` with nothing of d2sr in it: its own IDL for sensor_msgs/Image,
sensor_msgs/CameraInfo and diagnostic_msgs/DiagnosticStatus, Cyclone DDS's own serializer, as any ROS 2
node on the wire would be. It publishes depth frames (and their camera_info) and collects what the node
sends back (the loopback test and the bench use it).
"""

from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@cache
def _store() -> Any:
    """rosbags' type store, made once: making it costs milliseconds, which a reader of 640x480 frames at
    30 Hz paid twice a frame (16 ms a frame read, half a core)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]

    @classmethod
    def deserialize(cls, data, has_header=True, use_version_2=None):  # noqa: ANN001, ANN206
        """Read with rosbags' CDR codec: Cyclone's generic one builds a list of 600,000 ints per frame, tens
        of ms of the peer's CPU that the node on the same two cores would pay for. Writing keeps Cyclone's."""
        m = _store().deserialize_cdr(data, "sensor_msgs/msg/Image")
        head = Header(Time(m.header.stamp.sec, m.header.stamp.nanosec), m.header.frame_id)
        return cls(head, m.height, m.width, m.encoding, m.is_bigendian, m.step, m.data)


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue] = field(default_factory=list)


@dataclass
class RegionOfInterest(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


@dataclass
class CameraInfo(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: sequence[float64] = field(default_factory=list)
    k: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    r: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    p: array[float64, 12] = field(default_factory=lambda: [0.0] * 12)
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: sequence[uint8] = field(default_factory=list)


def compressed_depth(depth: np.ndarray, sec: int, nanosec: int = 0) -> CompressedImage:
    """A 16UC1 frame as image_transport's compressedDepth plugin sends it: a 12-byte header (format 0,
    two zero quantization floats), then a 16-bit PNG."""
    import struct

    import cv2

    ok, png = cv2.imencode(".png", depth)
    assert ok
    data = struct.pack("<iff", 0, 0.0, 0.0) + png.tobytes()
    return CompressedImage(Header(Time(sec, nanosec), "depth"), "16UC1; compressedDepth png", list(data))


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header = field(default_factory=Header)
    status: sequence[DiagnosticStatus] = field(default_factory=list)


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, 24] = field(default_factory=lambda: [0] * 24)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: str = ""
    node_name: str = ""
    reader_gid_seq: sequence[Gid] = field(default_factory=list)
    writer_gid_seq: sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: sequence[NodeEntitiesInfo] = field(default_factory=list)


def graph(dp: DomainParticipant) -> DataReader:
    """A reader of ``ros_discovery_info`` as ROS 2's tools (Humble) open it: reliable, transient local."""
    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.History.KeepLast(1),
        Policy.Durability.TransientLocal,
    )
    return DataReader(dp, Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo), qos=qos)


def camera_info(sec: int, nanosec: int = 0) -> CameraInfo:
    """An L515-like 640x480 calibration with a stamp (d2sr's own camera_info comes back with the image's)."""
    k = [461.2, 0.0, 329.2, 0.0, 461.6, 243.1, 0.0, 0.0, 1.0]
    p = [461.2, 0.0, 329.2, 0.0, 0.0, 461.6, 243.1, 0.0, 0.0, 0.0, 1.0, 0.0]
    r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    head = Header(Time(sec, nanosec), "camera_depth_optical_frame")
    return CameraInfo(head, 480, 640, "plumb_bob", [0.0] * 5, k, r, p, 0, 0, RegionOfInterest())


class Ready(Image):
    """An Image serialized once ahead of time (Cyclone's generic serializer takes ~35 ms for 640x480, too
    slow to publish at 30 Hz from one thread); the bytes are its own serializer's."""

    def serialize(self, buffer=None, endianness=None, use_version_2=None):  # noqa: ANN001, ANN201
        if not hasattr(self, "_bytes"):
            self._bytes = super().serialize(buffer, endianness, use_version_2)
        return self._bytes


def image(
    depth: np.ndarray, sec: int, nanosec: int = 0, frame_id: str = "camera_depth_optical_frame"
) -> Ready:
    """A message for ``depth`` stamped ``sec.nanosec``, serialized by Cyclone once per frame content: later
    stamps of the same frame only rewrite the stamp's 8 bytes (right after the 4-byte CDR header)."""
    key = (id(depth), frame_id)
    if key not in _SERIALIZED:
        # uint16 / float32 depth, or uint8 colour (HxWx3 bgr8, HxW mono8)
        enc = {np.dtype(np.uint16): "16UC1", np.dtype(np.float32): "32FC1"}.get(depth.dtype)
        if enc is None:
            enc = "bgr8" if depth.ndim == 3 else "mono8"
        h, w = depth.shape[:2]
        step = w * depth.itemsize * (depth.shape[2] if depth.ndim == 3 else 1)
        # bytes, not a list: a list of 600,000 ints per frame kept here made each of Python's full garbage
        # collections walk every cached frame, seconds with 300 frames, holding the peer's threads.
        data = np.ascontiguousarray(depth).view(np.uint8).reshape(-1).tobytes()
        _SERIALIZED[key] = (
            Ready(Header(Time(0, 0), frame_id), h, w, enc, 0, step, data),
            depth,
        )
    template = _SERIALIZED[key][0]
    msg = Ready(Header(Time(sec, nanosec), frame_id), template.height, template.width, template.encoding, 0,
                template.step, template.data)  # fmt: skip
    wire = bytearray(template.serialize())
    wire[4:12] = np.array([sec], "<i4").tobytes() + np.array([nanosec], "<u4").tobytes()
    msg._bytes = bytes(wire)
    return msg


_SERIALIZED: dict[tuple[int, str], tuple[Ready, np.ndarray]] = {}  # keeps each depth alive, so ids stay its


def pixels(msg: Image) -> np.ndarray:
    dtype = {"16UC1": np.uint16, "32FC1": np.float32, "mono8": np.uint8}[msg.encoding]
    return np.asarray(msg.data, np.uint8).view(dtype).reshape(msg.height, msg.width)


class Peer:
    """Publisher of ``topic`` and readers of its /repaired, /mask and /status, all reliable or all best-effort
    (a reliable reader does not match a best-effort writer)."""

    def __init__(
        self,
        domain: int,
        topic: str = "/camera/depth/image_rect_raw",
        reliable: bool = True,
        colour_topic: str | None = None,
        info: bool = False,
        diagnostics: bool = False,
        compressed: bool = False,
    ) -> None:
        # rosbags' codec made now, not on the first image read: made there (about a second on a busy
        # machine) it held every thread of the peer, its publisher's too, and delayed the first frames.
        Image.deserialize(Image(Header(Time(0, 0), ""), 1, 1, "16UC1", 0, 2, [0, 0]).serialize())
        self.dp = DomainParticipant(domain)
        name = "rt" + topic
        rel = Policy.Reliability.Reliable(duration(seconds=1)) if reliable else Policy.Reliability.BestEffort
        self.writer = DataWriter(
            self.dp, Topic(self.dp, name, Image), qos=Qos(rel, Policy.History.KeepLast(8))
        )
        keep = Qos(rel, Policy.History.KeepLast(1000))
        self.readers = {
            "repaired": DataReader(self.dp, Topic(self.dp, name + "/repaired", Image), qos=keep),
            "mask": DataReader(self.dp, Topic(self.dp, name + "/mask", Image), qos=keep),
            "status": DataReader(self.dp, Topic(self.dp, name + "/status", DiagnosticStatus), qos=keep),
        }
        self.info = None
        if info:  # camera_info beside the input (image_transport's pairing); the node's beside /repaired
            parent = name.rsplit("/", 1)[0]
            qos = Qos(rel, Policy.History.KeepLast(8))
            self.info = DataWriter(self.dp, Topic(self.dp, parent + "/camera_info", CameraInfo), qos=qos)
            self.readers["camera_info"] = DataReader(
                self.dp, Topic(self.dp, name + "/camera_info", CameraInfo), qos=keep
            )
        if compressed:  # image_transport's compressedDepth: in beside the topic, out beside /repaired
            qos = Qos(rel, Policy.History.KeepLast(8))
            self.writer = DataWriter(
                self.dp, Topic(self.dp, name + "/compressedDepth", CompressedImage), qos=qos
            )
            self.readers["compressed"] = DataReader(
                self.dp, Topic(self.dp, name + "/repaired/compressedDepth", CompressedImage), qos=keep
            )
        if diagnostics:
            self.readers["diagnostics"] = DataReader(
                self.dp, Topic(self.dp, "rt/diagnostics", DiagnosticArray), qos=keep
            )
        self.colour = None
        if colour_topic is not None:
            qos = Qos(rel, Policy.History.KeepLast(8))
            self.colour = DataWriter(self.dp, Topic(self.dp, "rt" + colour_topic, Image), qos=qos)
            self.readers["confidence"] = DataReader(
                self.dp, Topic(self.dp, name + "/confidence", Image), qos=keep
            )

    def matched(self) -> bool:
        """The node subscribes to our topics and we to all of its."""
        if not self.writer.get_matched_subscriptions():
            return False
        if self.colour is not None and not self.colour.get_matched_subscriptions():
            return False
        if self.info is not None and not self.info.get_matched_subscriptions():
            return False
        return all(r.get_matched_publications() for r in self.readers.values())

    def take(self) -> dict[str, list]:
        return {k: [s for s in r.take(N=1000) if s.sample_info.valid_data] for k, r in self.readers.items()}

    def listen(self) -> None:
        """Take replies on a thread of its own as they come, noting when each repaired frame arrived
        (``got``, ``arrived``: time.monotonic by stamp seconds); ``stop`` ends it."""
        import threading
        import time

        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet

        self.got: dict[str, list] = {k: [] for k in self.readers}
        self.arrived: dict[int, float] = {}
        self._stop = threading.Event()
        ws = WaitSet(self.dp)
        for r in self.readers.values():
            ws.attach(ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any))

        def run() -> None:
            while not self._stop.is_set():
                ws.wait(duration(milliseconds=50))
                now = time.monotonic()
                for key, new in self.take().items():
                    self.got[key] += new
                    if key == "repaired":
                        for m in new:
                            self.arrived.setdefault(m.header.stamp.sec, now)

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()
