"""A ROS 2 peer of ``d2sr ros2`` with nothing of d2sr in it: its own IDL for sensor_msgs/Image and
diagnostic_msgs/DiagnosticStatus, Cyclone DDS's own serializer, as any ROS 2 node on the wire would be.
It publishes depth frames and collects what the node sends back (the loopback test and the bench use it).
"""

from dataclasses import dataclass, field

import numpy as np
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int32, sequence, uint8, uint32
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


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]


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
    enc = {np.dtype(np.uint16): "16UC1", np.dtype(np.float32): "32FC1"}[depth.dtype]
    h, w = depth.shape
    data = list(np.ascontiguousarray(depth).view(np.uint8).reshape(-1))
    msg = Ready(Header(Time(sec, nanosec), frame_id), h, w, enc, 0, w * depth.itemsize, data)
    msg.serialize()
    return msg


def pixels(msg: Image) -> np.ndarray:
    dtype = {"16UC1": np.uint16, "32FC1": np.float32, "mono8": np.uint8}[msg.encoding]
    return np.asarray(msg.data, np.uint8).view(dtype).reshape(msg.height, msg.width)


class Peer:
    """Publisher of ``topic`` and readers of its /repaired, /mask and /status, all reliable or all best-effort
    (a reliable reader does not match a best-effort writer)."""

    def __init__(
        self, domain: int, topic: str = "/camera/depth/image_rect_raw", reliable: bool = True
    ) -> None:
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

    def matched(self) -> bool:
        """The node subscribes to our topic and we to all three of its."""
        if not self.writer.get_matched_subscriptions():
            return False
        return all(r.get_matched_publications() for r in self.readers.values())

    def take(self) -> dict[str, list]:
        return {k: [s for s in r.take(N=1000) if s.sample_info.valid_data] for k, r in self.readers.items()}
