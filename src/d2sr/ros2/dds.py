"""One DDS participant with ROS 2's names and the node's QoS per stream: what a node and its cameras open
their readers and writers through."""

from __future__ import annotations

import os
import tempfile
from typing import Any

from d2sr.errors import ConfigError, InputError
from d2sr.ros2.wire import Wire, dds_topic

__all__ = ["RECEIVE_BUFFER", "Dds"]

# A 640x480 depth image is 600 kB in about 450 datagrams, and several cameras' frames of one moment arrive
# together; Cyclone's default socket buffer is the host's default (about 200 kB on Linux), which overflowed
# and lost the third camera's frames (lab.ros2_loopback --cameras 3: 115 of 150 taken, 150 with this). The
# host's net.core.rmem_max caps it, never an error. A user's own CYCLONEDDS_URI is left as it is.
RECEIVE_BUFFER = "8MB"
_CONFIG = (
    "<CycloneDDS><Domain><Internal>"
    f'<SocketReceiveBufferSize max="{RECEIVE_BUFFER}"/>'
    "</Internal></Domain></CycloneDDS>"
)


class Dds:
    """A participant in ``domain``; ``reader``/``writer`` take a ROS 2 topic name (resolved and remapped by
    ``wire``) and the stream whose QoS they use."""

    def __init__(self, wire: Wire, domain: int) -> None:
        try:
            from cyclonedds.core import Policy, Qos
            from cyclonedds.domain import DomainParticipant
            from cyclonedds.pub import DataWriter
            from cyclonedds.sub import DataReader
            from cyclonedds.topic import Topic
            from cyclonedds.util import duration
        except ImportError:
            raise InputError("d2sr ros2 needs Cyclone DDS: pip install '.[ros2]'") from None
        self.wire, self.domain = wire, domain
        self._policy, self._qos, self._duration = Policy, Qos, duration
        self._reader, self._writer, self._topic = DataReader, DataWriter, Topic
        self.configured = _configured(domain)  # kept: the domain lives as long as this object
        self.participant = _participant(DomainParticipant, domain)
        self._topics: dict[str, Any] = {}

    def qos(self, stream: str) -> Any:
        reliable, depth = self.wire.profile(stream)
        p = self._policy
        how = (
            p.Reliability.Reliable(self._duration(milliseconds=100)) if reliable else p.Reliability.BestEffort
        )
        return self._qos(how, p.History.KeepLast(depth))

    def topic(self, name: str, kind: Any) -> Any:
        """The DDS topic of ROS 2 topic ``name`` (resolved, remapped), made once per name."""
        dds = dds_topic(self.wire.resolve(name))
        if dds not in self._topics:
            self._topics[dds] = self._topic(self.participant, dds, kind)
        return self._topics[dds]

    def reader(self, name: str, kind: Any, stream: str) -> Any:
        return self._reader(self.participant, self.topic(name, kind), qos=self.qos(stream))

    def writer(self, name: str, kind: Any, stream: str) -> Any:
        return self._writer(self.participant, self.topic(name, kind), qos=self.qos(stream))

    def latched(self, dds_name: str, kind: Any) -> Any:
        """A writer to DDS topic ``dds_name`` (no ROS name) that keeps its last sample for late readers
        (transient local, as ROS 2's rmw writes ``ros_discovery_info``)."""
        p = self._policy
        qos = self._qos(p.Reliability.Reliable(self._duration(milliseconds=100)), p.History.KeepLast(1),
                        p.Durability.TransientLocal)  # fmt: skip
        return self._writer(self.participant, self._topic(self.participant, dds_name, kind), qos=qos)

    def duration(self, milliseconds: int) -> Any:
        return self._duration(milliseconds=milliseconds)


def _configured(domain: int) -> Any:
    """``domain`` with d2sr's receive buffer (``RECEIVE_BUFFER``), unless the user configured Cyclone
    (``CYCLONEDDS_URI``) or the domain already runs in this process (another participant made it: it keeps
    its own configuration); None then."""
    if os.environ.get("CYCLONEDDS_URI"):
        return None
    from cyclonedds.core import DDSException
    from cyclonedds.domain import Domain

    try:
        return Domain(domain, _CONFIG)
    except DDSException:
        return None


def _participant(factory: Any, domain: int) -> Any:
    """A DDS participant, or one line when Cyclone refuses its configuration (``CYCLONEDDS_URI``): what
    Cyclone itself prints of it is caught and its first line said in ours."""
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
