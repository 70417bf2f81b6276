"""The ROS 2 node's message handler fed malformed messages: each is dropped (one warning per kind), the node
keeps running, the real frames after them come back, and what it keeps stays bounded however many come."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from d2sr.errors import ConfigError
from helpers import room


@dataclass
class Stamp:
    sec: int = 1
    nanosec: int = 0


@dataclass
class Header:
    stamp: Stamp = field(default_factory=Stamp)
    frame_id: str = "cam"


@dataclass
class Msg:
    height: int
    width: int
    encoding: str
    step: int
    data: bytes
    is_bigendian: int = 0
    header: Header = field(default_factory=Header)


def _real(i: int) -> Msg:
    depth = room(i, (120, 160), 1000.0)
    return Msg(120, 160, "16UC1", 320, depth.tobytes(), header=Header(Stamp(10 + i, 0)))


@pytest.fixture(scope="module")
def node(weights):
    pytest.importorskip("cyclonedds")
    from d2sr.ros2 import Ros2Node, Wire

    n = Ros2Node("/hostile/depth", 1000.0, Wire(domain=177), models=weights, model="unet8", scene=False)
    lines: list[str] = []
    n.say = lines.append
    cam = n.cameras[0]
    cam.lines = lines
    yield cam
    n.close()


MALFORMED = [
    Msg(480, 0, "16UC1", 0, b""),  # width 0 (killed the node before)
    Msg(0, 640, "16UC1", 1280, b""),
    Msg(1, 1, "16UC1", 2, b"\x01\x00"),
    Msg(480, 640, "16UC1", 1280, b"\x00" * 100),  # step and data disagree
    Msg(480, 640, "16UC1", 10, b"\x00" * (480 * 640 * 2)),  # step shorter than a row
    Msg(480, 640, "rgb8", 1920, b"\x00" * (480 * 640 * 3)),  # not depth
    Msg(7240, 7240, "16UC1", 14480, b""),  # over the pixel budget: refused before any allocation
    Msg(2**31, 2**31, "16UC1", 2**32, b""),
    Msg(120, 160, "32FC1", 640, np.full(120 * 160, np.nan, np.float32).tobytes()),
    Msg(120, 160, "16UC1", 320, b"\x00" * 38400, header=None),  # type: ignore[arg-type]
]


def test_malformed_messages_are_dropped_and_real_frames_still_answered(node):
    before = node.stats.published
    for m in MALFORMED:
        node.handle(m, time.monotonic())
    for i in range(3):
        node.handle(_real(i), time.monotonic())
    while node.running:
        node.publish_done(wait=True)
    assert node.stats.published - before == 3
    assert node.stats.refused >= 8
    assert len(node.lines) <= len(MALFORMED)  # one warning per kind, not per message


def test_warnings_and_figures_stay_bounded(node):
    said = len(node.lines)
    for i in range(20_000):
        node.handle(Msg(480, i % 7, "16UC1", 0, b""), time.monotonic())
        node.handle(Msg(2, 2, f"enc{i}", 4, b"\x00" * 16), time.monotonic())
    assert len(node.lines) - said <= 2  # the size kind was said before; one line for unknown encodings
    assert len(node._warned) <= 64
    node.stats.seconds.extend([0.01] * 50_000)
    assert len(node.stats.seconds) == node.stats.seconds.maxlen


_FIELDS = st.builds(
    Msg,
    st.integers(-2, 5000), st.integers(-2, 5000),
    st.sampled_from(["16UC1", "mono16", "32FC1", "8UC1", "", "16uc1"]),
    st.integers(-4, 20000), st.binary(max_size=2048), st.integers(0, 1),
)  # fmt: skip


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_FIELDS)
def test_random_messages_never_stop_the_node(node, msg):
    """Each message ends one way, counted (published, refused or dropped), and a real frame after it is
    still answered: a handler that returned at once, or one that stopped, fails here."""
    st = node.stats

    def ends() -> int:
        return st.published + st.refused + st.dropped

    before = ends()
    node.handle(msg, time.monotonic())
    while node.running:
        node.publish_done(wait=True)
    assert ends() - before == 1
    published = st.published
    node.handle(_real(0), time.monotonic())
    while node.running:
        node.publish_done(wait=True)
    assert st.published == published + 1


def test_settings_are_checked_at_start(weights):
    pytest.importorskip("cyclonedds")
    from d2sr.ros2 import Ros2Node, Wire

    for scale in (-1, 0, float("nan"), "abc"):
        with pytest.raises(ConfigError, match="depth_scale"):
            Ros2Node("/hostile/depth", scale, Wire(domain=178), models=weights, model="unet8")


class _Info:
    valid_data = True


class _Reader:
    """Hands over raw CDR samples as Cyclone's DataReader.take does: every sample of a take decoded in one
    call (``Image.deserialize``), then given its sample_info; ``fail`` makes the take itself raise."""

    def __init__(self, raws: list[bytes], fail: bool = False) -> None:
        self.raws, self.fail = raws, fail

    def take(self, N: int = 1) -> list:
        from d2sr.ros2.msgs import Image

        if self.fail:
            raise RuntimeError("the take failed")
        out = []
        for raw in self.raws[:N]:
            sample = Image.deserialize(raw)
            sample.sample_info = _Info()
            out.append(sample)
        self.raws = self.raws[N:]
        return out


def _wire(i: int) -> bytes:
    from d2sr.ros2.msgs import Header, Image, Time

    m = _real(i)
    return Image(Header(Time(20 + i, 0), "cam"), m.height, m.width, m.encoding, 0, m.step,
                 np.frombuffer(m.data, np.uint8)).serialize()  # fmt: skip


def test_bytes_that_are_not_an_image_are_refused_and_the_frames_beside_them_taken(node):
    """A peer without type information (another DDS, a fuzzer) can send any bytes under the topic's type
    name; Cyclone decodes a take's samples in one call, so one that raised there would stop the node."""
    good = _wire(0)
    junk = [b"", b"\x00\x01\x00\x00", good[:10], good[:40], good[:12] + b"\xff\xff\xff\x7f" + good[16:]]
    real = node.reader
    before, refused = node.stats.published, node.stats.refused
    try:
        node.reader = _Reader([junk[0], _wire(1), *junk[1:], _wire(2)])
        node.take(time.monotonic)
        node.reader = _Reader([_wire(3)], fail=True)
        node.take(time.monotonic)  # the take itself fails: said once, the node goes on
    finally:
        node.reader = real
    assert [m.header.stamp.sec for m, _ in node.waiting] == [21, 22]
    while node.waiting:
        node.start_oldest()
    while node.running:
        node.publish_done(wait=True)
    assert node.stats.published - before == 2
    assert node.stats.refused - refused == len(junk)
    assert any("not a readable image" in line for line in node.lines)
    assert any("a take failed" in line for line in node.lines)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600), st.integers(0, 80))
def test_any_bytes_decode_to_a_message_or_say_why(raw, cut):
    """Image and CompressedImage decode any bytes without raising: a message, or an empty one whose
    ``unreadable`` says why; a real message read back whole, cut short it is unreadable."""
    from d2sr.ros2.msgs import CompressedImage, Image, unreadable

    for kind in (Image, CompressedImage):
        m = kind.deserialize(raw)
        assert isinstance(m, kind)
        why = unreadable(m)
        assert why is None or (isinstance(why, str) and len(why) < 200)
    good = _wire(cut % 3)
    back = Image.deserialize(good)
    assert unreadable(back) is None and back.header.stamp.sec == 20 + cut % 3
    assert unreadable(Image.deserialize(good[: 4 + cut])) is not None
