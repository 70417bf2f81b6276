"""The node's DDS participant (``d2sr.ros2.dds``): its socket receive buffer, and a user's own Cyclone
configuration left alone."""

from __future__ import annotations

import random

from cyclonedds.domain import DomainParticipant

from d2sr.ros2.dds import Dds
from d2sr.ros2.wire import Wire

# Domains no other test uses (they pick 100-200): a domain another participant of this process made keeps its
# own configuration, which is the second test's case, not the first's.


def test_the_participant_asks_for_a_larger_receive_buffer_unless_the_user_configured_cyclone(monkeypatch):
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    dds = Dds(Wire(), random.randint(210, 219))
    assert dds.configured is not None  # RECEIVE_BUFFER asked for
    del dds
    monkeypatch.setenv("CYCLONEDDS_URI", "<CycloneDDS><Domain><General/></Domain></CycloneDDS>")
    dds = Dds(Wire(), random.randint(210, 219))
    assert dds.configured is None and dds.participant is not None  # the user's configuration, as given


def test_a_domain_already_running_in_the_process_keeps_its_configuration(monkeypatch):
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    domain = random.randint(220, 229)
    first = DomainParticipant(domain)  # a peer in the same process made the domain first
    dds = Dds(Wire(), domain)
    assert dds.configured is None and dds.participant is not None and first is not None
