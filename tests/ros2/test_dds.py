"""The node's DDS participant (``d2sr.ros2.dds``): its socket receive buffer, and a user's own Cyclone
configuration left alone."""

from __future__ import annotations

import os
import random
import socket
from pathlib import Path

from cyclonedds.domain import DomainParticipant

from d2sr.ros2.dds import Dds
from d2sr.ros2.wire import Wire

# Domains no other test uses (they pick 100-200): a domain another participant of this process made keeps its
# own configuration, which is the second test's case, not the first's.


def _udp_buffers() -> dict[int, int]:
    """This process's UDP sockets (by inode) and their receive buffers (bytes, as the kernel reports them)."""
    out = {}
    for fd in os.listdir("/proc/self/fd"):
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
            if not link.startswith("socket:"):
                continue
            s = socket.socket(fileno=os.dup(int(fd)))
        except OSError:
            continue
        with s:
            if s.type == socket.SOCK_DGRAM:
                out[int(link[8:-1])] = s.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
    return out


def test_the_participant_asks_for_a_larger_receive_buffer_unless_the_user_configured_cyclone(monkeypatch):
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    ours_domain = random.randint(210, 214)  # the user's below is another: one running keeps its own
    before = _udp_buffers()
    dds = Dds(Wire(), ours_domain)
    assert dds.configured is not None  # RECEIVE_BUFFER asked for ...
    ours = [v for k, v in _udp_buffers().items() if k not in before]
    monkeypatch.setenv("CYCLONEDDS_URI", "<CycloneDDS><Domain><General/></Domain></CycloneDDS>")
    before = _udp_buffers()
    user = Dds(Wire(), ours_domain + 5)
    assert user.configured is None and user.participant is not None  # the user's configuration, as given
    theirs = [v for k, v in _udp_buffers().items() if k not in before]
    # ... and its sockets have it: more than Cyclone gives by itself (1 MB asked), unless the host caps both.
    cap = int(Path("/proc/sys/net/core/rmem_max").read_text())
    assert ours and theirs and (max(ours) > max(theirs) or (cap <= 2**20 and os.geteuid() != 0))
    del dds, user


def test_a_domain_already_running_in_the_process_keeps_its_configuration(monkeypatch):
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    domain = random.randint(220, 229)
    first = DomainParticipant(domain)  # a peer in the same process made the domain first
    dds = Dds(Wire(), domain)
    assert dds.configured is None and dds.participant is not None and first is not None
