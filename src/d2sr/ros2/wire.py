"""How the node meets the DDS world: ROS 2's names (namespaces, remapping, ``rt/`` topics), the domain, and
QoS per stream (REP 2003)."""

from __future__ import annotations

import functools
import os
import re
from dataclasses import dataclass

from d2sr.errors import ConfigError

__all__ = ["PROFILES", "QOS", "STREAMS_IN", "STREAMS_OUT", "TRANSPORTS", "Wire", "dds_topic", "domain_id"]

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
#: The longest fully qualified topic name ROS 2 takes (rmw's RMW_TOPIC_MAX_NAME_LENGTH, 255 less 8 for
#: DDS's prefixes): Cyclone crashed on a name of 65,536 characters.
MAX_NAME = 255 - 8
_NODE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def dds_topic(name: str) -> str:
    """ROS 2 topic ``/a/b`` (or ``a/b``) -> DDS topic ``rt/a/b``, or a ConfigError for a name ROS refuses."""
    _check_name(name, "topic")
    return "rt/" + name.lstrip("/")


def _check_name(name: str, setting: str) -> None:
    """A ConfigError for a name ROS 2 refuses: its characters (checked only within the length), its length;
    ``setting``: what gave the name (the CLI says its flag)."""
    if len("/" + name.lstrip("/")) > MAX_NAME:
        raise ConfigError(
            f"{setting}: a topic name of {len(name)} characters; ROS 2 takes at most {MAX_NAME}", setting
        )
    if not _NAME.match(name):
        raise ConfigError(
            f"{setting}: {name[:80]!r} is not a ROS 2 topic name (letters, digits, _ and /)", setting
        )


def domain_id() -> int:
    """``ROS_DOMAIN_ID`` (0 when unset), as ROS 2 reads it."""
    raw = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
    if not raw.isdigit() or int(raw) > 232:
        raise ConfigError(f"ROS_DOMAIN_ID must be a number in 0..232, got {raw!r}")
    return int(raw)


@dataclass(frozen=True)
class Wire:
    """How a node meets the DDS world: ``qos``, its publishers' reliability (the subscriber takes both
    kinds); ``domain`` (default ``ROS_DOMAIN_ID``); ``transport``, how images travel (``TRANSPORTS``);
    ``node_name`` and ``namespace``, as ROS 2's tools list the node; ``streams``, a stream's own QoS;
    ``remaps``, ROS 2's remapping rules (``from:=to``: a topic the node reads or writes, ``__node`` or
    ``__ns``), applied after the namespace as ``--ros-args -r`` applies them."""

    qos: str = "reliable"
    domain: int | None = None
    transport: str = "raw"
    node_name: str = "d2sr"
    namespace: str = "/"  # the node's; a relative topic name resolves under it, as in ROS 2
    streams: tuple[tuple[str, str], ...] = ()  # (stream, profile): a stream's own QoS (``PROFILES``)
    remaps: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.qos not in QOS:
            raise ConfigError(f"qos must be one of {', '.join(QOS)}, got {self.qos!r}", "qos")
        if self.transport not in TRANSPORTS:
            raise ConfigError(
                f"transport must be one of {', '.join(TRANSPORTS)}, got {self.transport!r}", "transport"
            )
        for stream, profile in self.streams:
            if stream not in STREAMS_IN + STREAMS_OUT or profile not in PROFILES:
                raise ConfigError(f"{stream}_qos: {profile!r} is not one of {', '.join(PROFILES)}")
        self._rules  # noqa: B018  (checked here, when made)

    @functools.cached_property
    def _rules(self) -> tuple[str, str, dict[str, str]]:
        """(node name, namespace, {resolved topic: resolved topic}) after the remapping rules."""
        node, ns, topics = self.node_name, self.namespace, {}
        for rule in self.remaps:
            src, sep, dst = rule.partition(":=")
            if not sep or not src or not dst:
                raise ConfigError(f"remap: {rule!r} is not a rule FROM:=TO", "remap")
            if src == "__node":
                node = dst
            elif src == "__ns":
                ns = dst
        if not _NODE.match(node):
            raise ConfigError(f"{node!r} is not a ROS 2 node name (letters, digits and _)", "node_name")
        if not ns.startswith("/") or (ns != "/" and not _NAME.match(ns)):
            raise ConfigError(f"{ns!r} is not a ROS 2 namespace (/ or /a/b)", "namespace")
        for rule in self.remaps:
            src, _, dst = rule.partition(":=")
            if src not in ("__node", "__ns"):
                topics[_resolve(src, ns, "remap")] = _resolve(dst, ns, "remap")
        return node, ns, topics

    @property
    def name(self) -> str:
        """The node's name, after ``__node:=``."""
        return self._rules[0]

    @property
    def space(self) -> str:
        """The node's namespace, after ``__ns:=``."""
        return self._rules[1]

    def resolve(self, topic: str) -> str:
        """A topic's full ROS 2 name: a relative one under the node's namespace, then remapped."""
        _, ns, topics = self._rules
        full = _resolve(topic, ns, "topic")
        return topics.get(full, full)

    def profile(self, stream: str) -> tuple[bool, int]:
        """(reliable, history depth) of ``stream``: its own profile, else sensor data for what the node
        reads and ``qos`` for what it writes."""
        own = dict(self.streams).get(stream)
        if own is not None:
            return PROFILES[own]
        if stream in STREAMS_IN:
            return PROFILES["SENSOR_DATA"]
        return PROFILES["SYSTEM_DEFAULT" if self.qos == "reliable" else "SENSOR_DATA"]


def _resolve(topic: str, namespace: str, setting: str) -> str:
    """``topic`` as ROS 2 resolves it in ``namespace`` (no ``~``: the node has no private topics)."""
    _check_name(topic, setting)
    full = topic if topic.startswith("/") else namespace.rstrip("/") + "/" + topic
    _check_name(full, setting)
    return full
