"""ROS 2 message types as Cyclone DDS IDL structs, in the layout ROS 2 puts on the wire (XCDR1, little
endian). ``Image`` keeps Cyclone's type information (so ROS 2 nodes match it) but encodes and decodes its
pixels through rosbags' CDR codec: Cyclone's generic one packs a depth image byte by byte and returns a
list; rosbags gives the same bytes at memory speed and a numpy array back."""

from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int32, sequence, uint8, uint32

__all__ = [
    "GID_BYTES",
    "CameraInfo",
    "CompressedImage",
    "DiagnosticArray",
    "DiagnosticStatus",
    "Gid",
    "Header",
    "Image",
    "KeyValue",
    "NodeEntitiesInfo",
    "ParticipantEntitiesInfo",
    "RegionOfInterest",
    "Time",
    "unreadable",
    "warm_codecs",
]

IMAGE = "sensor_msgs/msg/Image"


@cache
def _store() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _encode(kind: str, header: "Header", data: Any, **fields: Any) -> bytes:
    """A message of ``kind`` (``IMAGE``, ``COMPRESSED``) with ``header`` and pixel ``data`` as CDR bytes,
    through rosbags' codec."""
    ts = _store()
    t = ts.types
    stamp = t["builtin_interfaces/msg/Time"](sec=header.stamp.sec, nanosec=header.stamp.nanosec)
    head = t["std_msgs/msg/Header"](stamp=stamp, frame_id=header.frame_id)
    pixels = np.ascontiguousarray(data, dtype=np.uint8).reshape(-1)
    return bytes(ts.serialize_cdr(t[kind](header=head, data=pixels, **fields), kind))


def warm_codecs() -> None:
    """Make rosbags' type store and the codecs it writes on first use, for every image type the node reads
    and writes, before the first message: made on the first frame taken, they held the node's loop while a
    30 Hz stream's frames were overwritten in its reader (a reader keeps 5)."""
    pixels = np.zeros(2, np.uint8)
    Image.deserialize(Image(Header(), 1, 1, "16UC1", 0, 2, pixels).serialize())
    CompressedImage.deserialize(CompressedImage(Header(), "16UC1; compressedDepth png", pixels).serialize())


def _decode(data: bytes, kind: str) -> tuple[Any, "Header"] | str:
    """(rosbags' message of ``kind`` from CDR ``data``, its header as ours), or why it cannot be read."""
    try:
        m = _store().deserialize_cdr(data, kind)
        return m, Header(Time(m.header.stamp.sec, m.header.stamp.nanosec), m.header.frame_id)
    except Exception as exc:  # rosbags raises its own and Python's errors on bytes that are not CDR
        return f"{type(exc).__name__}: {(str(exc).splitlines() or ['no detail'])[0][:80]}"


def unreadable(msg: Any) -> str | None:
    """Why a message taken off the wire could not be decoded (None for one that was): Cyclone decodes
    every sample of a take in one call, so a message that raised there would lose the others with it and
    stop the node; it comes out as an empty message that says so instead."""
    return getattr(msg, "_unreadable", None)


def _unread(msg: Any, why: str) -> Any:
    msg._unreadable = why
    return msg


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    encoding: str = ""
    is_bigendian: uint8 = 0
    step: uint32 = 0
    data: sequence[uint8] = field(default_factory=list)  # a numpy uint8 array on d2sr's side

    def serialize(self, buffer: Any = None, endianness: Any = None, use_version_2: Any = None) -> bytes:
        return _encode(
            IMAGE, self.header, self.data, height=self.height, width=self.width, encoding=self.encoding,
            is_bigendian=self.is_bigendian, step=self.step,
        )  # fmt: skip

    @classmethod
    def deserialize(cls, data: bytes, has_header: bool = True, use_version_2: Any = None) -> "Image":
        got = _decode(data, IMAGE)
        if isinstance(got, str):
            return _unread(cls(), got)
        m, header = got
        return cls(header, m.height, m.width, m.encoding, m.is_bigendian, m.step, m.data)


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8 = 0  # diagnostic_msgs' byte: 0 OK, 1 WARN, 2 ERROR, 3 STALE
    name: str = ""
    message: str = ""
    hardware_id: str = ""
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
    """The camera's calibration beside an image (image_transport pairs ``<ns>/image`` with
    ``<ns>/camera_info``)."""

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
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    """``/diagnostics``: one status per camera (what ROS 2's diagnostic tools read)."""

    header: Header = field(default_factory=Header)
    status: sequence[DiagnosticStatus] = field(default_factory=list)


COMPRESSED = "sensor_msgs/msg/CompressedImage"


@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    """image_transport's compressed images (``<topic>/compressedDepth``: a 12-byte header, then a PNG),
    its bytes through rosbags' codec as ``Image``'s."""

    header: Header = field(default_factory=Header)
    format: str = ""
    data: sequence[uint8] = field(default_factory=list)

    def serialize(self, buffer: Any = None, endianness: Any = None, use_version_2: Any = None) -> bytes:
        return _encode(COMPRESSED, self.header, self.data, format=self.format)

    @classmethod
    def deserialize(
        cls, data: bytes, has_header: bool = True, use_version_2: Any = None
    ) -> "CompressedImage":
        got = _decode(data, COMPRESSED)
        if isinstance(got, str):
            return _unread(cls(), got)
        m, header = got
        return cls(header, m.format, m.data)


#: A graph id's size on the wire: the 16-byte DDS GUID, padded with zeros to 24 bytes (ROS 2 Humble's
#: rmw_dds_common; Jazzy shrank it to 16: a Jazzy graph does not read Humble's, and the other way round).
GID_BYTES = 24


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, GID_BYTES] = field(default_factory=lambda: [0] * GID_BYTES)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: str = ""
    node_name: str = ""
    reader_gid_seq: sequence[Gid] = field(default_factory=list)
    writer_gid_seq: sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    """``ros_discovery_info``: the nodes of a DDS participant and their readers and writers, which is how
    ``ros2 node list`` and ``ros2 node info`` learn of nodes."""

    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: sequence[NodeEntitiesInfo] = field(default_factory=list)
