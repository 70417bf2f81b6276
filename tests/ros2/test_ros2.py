"""d2sr ros2: the messages' CDR bytes against rosbags' serializer, topic and domain rules, and the node in a
process of its own against a separate DDS participant with its own IDL (tools/ros2_peer.py)."""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_typestore
from tools import ros2_peer

from d2sr.errors import ConfigError
from d2sr.ros2 import dds_topic
from d2sr.ros2.msgs import DiagnosticStatus, Header, Image, KeyValue, Time
from d2sr.ros2.wire import domain_id
from helpers import d2sr_inprocess, room

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types


def _rosbags_image(depth: np.ndarray, encoding: str):
    h, w = depth.shape
    return T["sensor_msgs/msg/Image"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=7, nanosec=11), frame_id="cam"
        ),
        height=h, width=w, encoding=encoding, is_bigendian=0, step=w * depth.itemsize,
        data=np.ascontiguousarray(depth).view(np.uint8).reshape(-1),
    )  # fmt: skip


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_image_bytes_are_rosbags_bytes_both_ways(dtype):
    depth = np.random.default_rng(0).integers(0, 9000, (6, 10)).astype(dtype)
    ours = Image(Header(Time(7, 11), "cam"), 6, 10, "16UC1" if dtype == np.uint16 else "32FC1", 0,
                 10 * depth.itemsize, depth.view(np.uint8).reshape(-1))  # fmt: skip
    wire = ours.serialize()
    theirs = TS.serialize_cdr(_rosbags_image(depth, ours.encoding), "sensor_msgs/msg/Image")
    assert wire == bytes(theirs)
    peer = ros2_peer.image(depth, 7, 11, "cam")  # Cyclone's own serializer, the peer's own IDL
    assert peer.serialize() == wire
    back = Image.deserialize(wire)
    assert back.header == Header(Time(7, 11), "cam") and back.encoding == ours.encoding
    assert np.array_equal(np.asarray(back.data).view(dtype).reshape(6, 10), depth)


def test_status_bytes_are_rosbags_bytes():
    ours = DiagnosticStatus(
        1, "d2sr", "interfered", "/cam", [KeyValue("score", "0.9"), KeyValue("period", "3")]
    )
    kv = T["diagnostic_msgs/msg/KeyValue"]
    theirs = T["diagnostic_msgs/msg/DiagnosticStatus"](
        level=1, name="d2sr", message="interfered", hardware_id="/cam",
        values=[kv(key="score", value="0.9"), kv(key="period", value="3")],
    )  # fmt: skip
    assert ours.serialize() == bytes(TS.serialize_cdr(theirs, "diagnostic_msgs/msg/DiagnosticStatus"))


def test_ros_names_and_domains():
    assert dds_topic("/camera/depth/image_rect_raw") == "rt/camera/depth/image_rect_raw"
    assert dds_topic("cam/depth") == "rt/cam/depth"
    for bad in ("", "/", "/cam//depth", "/cam/9depth", "/cam depth"):
        with pytest.raises(ConfigError, match="is not a ROS 2 topic name"):
            dds_topic(bad)
    os.environ["ROS_DOMAIN_ID"] = "12"
    try:
        assert domain_id() == 12
        os.environ["ROS_DOMAIN_ID"] = "300"
        with pytest.raises(ConfigError, match=r"ROS_DOMAIN_ID must be a number in 0\.\.232"):
            domain_id()
    finally:
        del os.environ["ROS_DOMAIN_ID"]
    assert domain_id() == 0


def test_bad_options_are_one_line_errors():
    code, _, err = d2sr_inprocess("ros2", "--topic", "/cam depth")
    assert code == 2 and err.count("\n") == 1 and "is not a ROS 2 topic name" in err
    code, _, err = d2sr_inprocess("ros2", "--topic", "/cam", "--qos", "fast")
    assert code == 2 and "qos must be one of reliable, best-effort" in err and "(set by --qos)" in err


def _node(domain: int, *args: str) -> subprocess.Popen:
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    cmd = [sys.executable, "-m", "d2sr", "ros2", "--topic", "/camera/depth/image_rect_raw", *args]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _exchange(
    peer: ros2_peer.Peer, frames: list[np.ndarray], hz: float, lockstep: bool = False
) -> dict[str, list]:
    """Publish ``frames`` at ``hz`` and take what comes back. ``lockstep``: each frame once the one before
    came back, so that a loaded machine drops none (what the node does when behind is tested apart)."""
    end = time.monotonic() + 30
    while not peer.matched():
        assert time.monotonic() < end, "the node never matched the peer's topics"
        time.sleep(0.05)
    got: dict[str, list] = {"repaired": [], "mask": [], "status": []}
    for k, f in enumerate(frames):
        peer.writer.write(ros2_peer.image(f, 1000 + k, 500))
        time.sleep(1 / hz)
        if lockstep:
            _collect(peer, got, lambda k=k: len(got["repaired"]) > k, seconds=60)
    end = time.monotonic() + 10
    while time.monotonic() < end and min(len(v) for v in got.values()) < len(frames):
        for key, new in peer.take().items():
            got[key] += new
        time.sleep(0.05)
    return got


def _collect(
    peer: ros2_peer.Peer, got: dict[str, list], done: Callable[[], bool], seconds: float = 10
) -> None:
    """Take what the node sends into ``got`` (its keys only) until ``done()`` or ``seconds`` have passed."""
    end = time.monotonic() + seconds
    while time.monotonic() < end and not done():
        for key, new in peer.take().items():
            if key in got:
                got[key] += new
        time.sleep(0.05)


@pytest.mark.slow
@pytest.mark.parametrize("reliable", [True, False])
def test_node_in_its_own_process_repairs_what_a_separate_participant_publishes(reliable):
    domain = random.randint(100, 200)
    node = _node(domain, "--depth-scale", "4000", "--qos", "reliable" if reliable else "best-effort")
    peer = ros2_peer.Peer(domain, reliable=reliable)
    from d2sr.sim.interference import corrupt

    frames = []
    for k in range(8):
        f = room(2 * k)
        if k % 2:
            where = np.zeros(f.shape, bool)
            where[150:260, :] = True
            f = corrupt(f, 4000.0, where, np.random.default_rng(k))[0]
        frames.append(f)
    try:
        got = _exchange(peer, frames, hz=10, lockstep=True)
    finally:
        node.send_signal(signal.SIGINT)
        out, err = node.communicate(timeout=30)
    assert node.returncode == 0, err
    assert "8 frames in, 8 out" in " ".join(out.split())
    stamps = sorted(m.header.stamp.sec for m in got["repaired"])
    assert stamps == list(range(1000, 1008))  # every frame, its stamp kept
    assert sorted(m.header.stamp.sec for m in got["mask"]) == stamps
    by_stamp = {m.header.stamp.sec: m for m in got["repaired"]}
    masks = {m.header.stamp.sec: ros2_peer.pixels(m) for m in got["mask"]}
    for k, f in enumerate(frames):
        rep = by_stamp[1000 + k]
        assert rep.encoding == "16UC1" and rep.header.stamp.nanosec == 500
        assert rep.header.frame_id == "camera_depth_optical_frame"
        mask = masks[1000 + k]
        assert set(np.unique(mask)) <= {0, 255}
        out_px = ros2_peer.pixels(rep)
        assert np.array_equal(out_px[mask == 0], f[mask == 0])  # only the mask changed
    status = {m.values[0].value: m for m in got["status"]}
    assert len(status) == 8
    flags = [dict((kv.key, kv.value) for kv in m.values)["interfered"] for m in got["status"]]
    assert flags.count("true") >= 3  # the corrupted frames are flagged
    first = dict((kv.key, kv.value) for kv in got["status"][0].values)
    assert first["synthesized"] == "false" and int(first["active_frames"]) == 6


@pytest.mark.slow
def test_node_keeps_float_metres_and_their_nan():
    domain = random.randint(100, 200)
    node = _node(domain)
    peer = ros2_peer.Peer(domain)
    metres = room(0).astype(np.float32) / 4000
    metres[metres == 0] = np.nan
    try:
        got = _exchange(peer, [metres], hz=10)
    finally:
        node.send_signal(signal.SIGINT)
        node.communicate(timeout=30)
    assert node.returncode == 0
    (rep,) = got["repaired"]
    assert rep.encoding == "32FC1"
    out = ros2_peer.pixels(rep)
    assert np.array_equal(np.isnan(out), np.isnan(metres))  # clean frame: nothing moved, NaN kept


@pytest.mark.slow
def test_node_synthesizes_the_frames_a_duty_cycled_laser_skips():
    """Colour at 30 Hz, depth only in slots 0-5 of every 30 (a camera walking past a textured wall): every
    colour frame without depth comes back as a synthesized depth frame, marked so, with its confidence."""
    from helpers import colour_of_wall, texture

    domain = random.randint(100, 200)
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    cmd = [sys.executable, "-m", "d2sr", "ros2", "--topic", "/camera/depth/image_rect_raw", "--repair",
           "none", "--colour-topic", "/camera/color/image_raw", "--depth-scale", "1000"]  # fmt: skip
    node = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peer = ros2_peer.Peer(domain, colour_topic="/camera/color/image_raw")
    tex = texture(3)
    wall = np.full((240, 320), 3000, np.uint16)
    colours = [colour_of_wall(np.array([0.004 * k, 0.0, 0.0]), tex) for k in range(45)]
    try:
        end = time.monotonic() + 30
        while not peer.matched():
            assert time.monotonic() < end, "the node never matched the peer's topics"
            time.sleep(0.05)
        peer.listen()
        for k in range(45):
            peer.colour.write(ros2_peer.image(colours[k], 2000, k * 33_333_333))
            if k % 30 < 6:
                peer.writer.write(ros2_peer.image(wall, 2000, k * 33_333_333))
            time.sleep(1 / 15)  # the stamps say 30 Hz; half the pace keeps a loaded machine from dropping
        end = time.monotonic() + 10
        while time.monotonic() < end and len(peer.got["repaired"]) < 45:
            time.sleep(0.05)
        peer.stop()
    finally:
        node.send_signal(signal.SIGINT)
        out, err = node.communicate(timeout=30)
    assert node.returncode == 0, err
    status = [dict((kv.key, kv.value) for kv in m.values) for m in peer.got["status"]]
    synth = [s for s in status if s["synthesized"] == "true"]
    # 45 slots, 12 with depth: each comes back with its own stamp or is counted as dropped (a loaded machine
    # drops some), and each skipped slot that comes back is synthesized.
    stamps = [(m.header.stamp.sec - 2000) * 10**9 + m.header.stamp.nanosec for m in peer.got["repaired"]]
    slots = [round(t / 33_333_333) for t in stamps]
    skipped = [k for k in slots if k % 30 >= 6]
    dropped = re.search(r"(\d+) dropped while behind", out)
    assert dropped is not None, out
    assert len(set(slots)) == len(slots) and set(slots) <= set(range(45))
    assert len(slots) + int(dropped.group(1)) == 45, out
    assert len(synth) == len(skipped) > 0
    assert {s["method"] for s in synth} == {"warp-colour"}
    assert len(peer.got["confidence"]) == len(synth)
    by_stamp = {m.header.stamp.nanosec: ros2_peer.pixels(m) for m in peer.got["repaired"]}
    conf = {m.header.stamp.nanosec: ros2_peer.pixels(m) for m in peer.got["confidence"]}
    for nano, c in conf.items():
        d = by_stamp[nano]
        sure = c == 255
        assert sure.mean() > 0.5 and np.abs(d[sure].astype(int) - 3000).max() <= 45


@pytest.mark.parametrize("scene", [True, False])
def test_node_takes_the_scene_option(scene):
    """``d2sr ros2 --scene``: the node's loop judges frames against the still sensor's scene once it has
    held still (``Repaired.scene`` True); without it the detector decides alone (None)."""
    from d2sr.ros2 import Ros2Node, Wire

    node = Ros2Node("/cam/depth", 4000.0, Wire(domain=random.randint(100, 200)), scene=scene)
    try:
        wall = room(0)
        weighed = [node.cameras[0].pipeline.process(wall.copy()).scene for _ in range(40)]
        assert weighed[-1] is (True if scene else None)
    finally:
        node.close()


def test_a_node_behind_drops_the_oldest_frames_not_started_and_counts_them():
    """Frames come faster than the repair: at most ``WAITING`` frames wait; older ones are dropped, counted
    and said once, never queued without bound; every frame is either published or counted as dropped."""
    from d2sr.ros2.camera import WAITING
    from d2sr.ros2.node import Ros2Node, Wire

    said: list[str] = []
    node = Ros2Node("/cam/depth", 4000.0, Wire(domain=random.randint(100, 200)), say=said.append)
    cam = node.cameras[0]
    slow = cam.pipeline.finish

    def finish(decided):  # a repair far slower than the frames come
        time.sleep(0.15)
        return slow(decided)

    cam.pipeline.finish = finish  # type: ignore[method-assign]
    try:
        depth = room(0)
        h, w = depth.shape
        n = 20
        for k in range(n):
            msg = Image(
                Header(Time(1000 + k, 0), "depth"), h, w, "16UC1", 0, 2 * w, depth.view(np.uint8).ravel()
            )
            cam.receive(msg, time.monotonic())
            node.start_waiting()
            assert len(cam.waiting) <= WAITING and len(cam.running) <= 2 * node._workers
        stats = node.spin(seconds=0.2)["/cam/depth"]
    finally:
        node.close()
    assert stats.received == n and stats.published + stats.dropped == n
    assert stats.dropped >= n - 2 * node._workers - WAITING
    assert sum("dropped" in line for line in said) == 1


def test_a_stream_nobody_reads_is_not_made():
    """The mask of each frame is made and written only while a reader subscribes to it; /repaired always."""
    from d2sr.ros2.node import Ros2Node, Wire

    class Writer:
        def __init__(self, readers: int) -> None:
            self.readers, self.sent = readers, []

        def get_matched_subscriptions(self) -> list[int]:
            return [1] * self.readers

        def write(self, m: Any) -> None:
            self.sent.append(m)

    node = Ros2Node("/cam/depth", 4000.0, Wire(domain=random.randint(100, 200)))
    cam = node.cameras[0]
    cam.repaired, cam.mask, cam.status = Writer(0), Writer(0), Writer(1)  # type: ignore[assignment]
    depth = room(0)
    h, w = depth.shape
    try:
        for k, readers in enumerate((0, 1)):
            cam.mask.readers = readers  # type: ignore[attr-defined]
            msg = Image(
                Header(Time(1000 + k, 0), "depth"), h, w, "16UC1", 0, 2 * w, depth.view(np.uint8).ravel()
            )
            cam.receive(msg, time.monotonic())
            node.start_waiting()
            cam.publish_done(wait=True)
    finally:
        node.close()
    assert len(cam.repaired.sent) == 2 and len(cam.status.sent) == 2  # type: ignore[attr-defined]
    assert [m.header.stamp.sec for m in cam.mask.sent] == [1001]  # type: ignore[attr-defined]


def test_camera_info_bytes_are_rosbags_bytes():
    from d2sr.ros2.msgs import CameraInfo, RegionOfInterest

    ts = get_typestore(Stores.ROS2_HUMBLE)
    t = ts.types
    ours = CameraInfo(Header(Time(5, 7), "cam"), 480, 640, "plumb_bob", [0.1, -0.2, 0.0, 0.0, 0.01],
                      [1.0] * 9, [2.0] * 9, [3.0] * 12, 1, 2, RegionOfInterest(1, 2, 3, 4, True))  # fmt: skip
    theirs = t["sensor_msgs/msg/CameraInfo"](
        t["std_msgs/msg/Header"](t["builtin_interfaces/msg/Time"](5, 7), "cam"), 480, 640, "plumb_bob",
        np.array([0.1, -0.2, 0.0, 0.0, 0.01]), np.full(9, 1.0), np.full(9, 2.0), np.full(12, 3.0), 1, 2,
        t["sensor_msgs/msg/RegionOfInterest"](1, 2, 3, 4, True),
    )  # fmt: skip
    assert ours.serialize() == bytes(ts.serialize_cdr(theirs, "sensor_msgs/msg/CameraInfo"))


@pytest.mark.slow
def test_node_republishes_camera_info_beside_repaired_with_each_frame_s_stamp():
    domain = random.randint(100, 200)
    node = _node(domain, "--depth-scale", "4000")
    peer = ros2_peer.Peer(domain, info=True, diagnostics=True)
    end = time.monotonic() + 30
    while not peer.matched():
        assert time.monotonic() < end, "the node never matched the peer's topics"
        time.sleep(0.05)
    got: dict[str, list] = {"repaired": [], "camera_info": [], "diagnostics": []}
    try:
        for k in range(5):
            assert peer.info is not None
            peer.info.write(ros2_peer.camera_info(1000 + k, 500))
            time.sleep(0.02)
            peer.writer.write(ros2_peer.image(room(k), 1000 + k, 500))
            time.sleep(0.1)
        _collect(peer, got, lambda: len(got["camera_info"]) >= 5 and len(got["diagnostics"]) >= 2)
    finally:
        node.send_signal(signal.SIGINT)
        node.communicate(timeout=30)
    stamps = [(m.header.stamp.sec, m.header.stamp.nanosec) for m in got["camera_info"]]
    # /diagnostics, once a second: this camera's counts, latency and window
    assert got["diagnostics"], "no /diagnostics in the run"
    last = {kv.key: kv.value for kv in got["diagnostics"][-1].status[0].values}
    assert got["diagnostics"][-1].status[0].hardware_id == "/camera/depth/image_rect_raw"
    assert int(last["frames_in"]) <= 5 and {"dropped", "latency_p99_ms", "window_offset"} <= set(last)
    assert stamps == [(m.header.stamp.sec, m.header.stamp.nanosec) for m in got["repaired"]]
    assert len(stamps) == 5 and got["camera_info"][0].k[0] == pytest.approx(461.2)


def test_diagnostics_bytes_are_rosbags_bytes():
    from d2sr.ros2.msgs import DiagnosticArray

    ts = get_typestore(Stores.ROS2_HUMBLE)
    t = ts.types
    status = DiagnosticStatus(1, "d2sr: /cam", "ok", "/cam", [KeyValue("frames_in", "3")])
    ours = DiagnosticArray(Header(Time(9, 1), ""), [status])
    theirs = t["diagnostic_msgs/msg/DiagnosticArray"](
        t["std_msgs/msg/Header"](t["builtin_interfaces/msg/Time"](9, 1), ""),
        [t["diagnostic_msgs/msg/DiagnosticStatus"](1, "d2sr: /cam", "ok", "/cam",
                                                   [t["diagnostic_msgs/msg/KeyValue"]("frames_in", "3")])],
    )  # fmt: skip
    assert ours.serialize() == bytes(ts.serialize_cdr(theirs, "diagnostic_msgs/msg/DiagnosticArray"))


@pytest.mark.slow
def test_node_takes_and_gives_compressed_depth():
    """--transport compressedDepth: TOPIC/compressedDepth in (a 12-byte header and a PNG, as image_transport's
    plugin sends it), TOPIC/repaired/compressedDepth out in the same layout, and the raw TOPIC/repaired beside
    it; every pixel the repair did not touch is as it came."""
    import struct

    import cv2

    domain = random.randint(100, 200)
    node = _node(domain, "--depth-scale", "4000", "--transport", "compressedDepth")
    peer = ros2_peer.Peer(domain, compressed=True)
    end = time.monotonic() + 30
    while not peer.matched():
        assert time.monotonic() < end, "the node never matched the peer's topics"
        time.sleep(0.05)
    frames = [room(k) for k in range(3)]
    got: dict[str, list] = {"repaired": [], "mask": [], "compressed": []}
    try:
        for k, f in enumerate(frames):  # each once the one before came back: a busy node drops none
            peer.writer.write(ros2_peer.compressed_depth(f, 1000 + k))
            _collect(peer, got, lambda k=k: min(len(v) for v in got.values()) > k, seconds=60)
    finally:
        node.send_signal(signal.SIGINT)
        node.communicate(timeout=30)
    assert len(got["compressed"]) == 3 and len(got["repaired"]) == 3
    for c, r, m in zip(got["compressed"], got["repaired"], got["mask"], strict=True):
        raw = bytes(c.data)
        assert c.format == "16UC1; compressedDepth png" and struct.unpack("<iff", raw[:12]) == (0, 0.0, 0.0)
        img = cv2.imdecode(np.frombuffer(raw[12:], np.uint8), cv2.IMREAD_UNCHANGED)
        assert img.dtype == np.uint16 and np.array_equal(img, ros2_peer.pixels(r))
        untouched = ros2_peer.pixels(m) == 0
        assert np.array_equal(img[untouched], frames[c.header.stamp.sec - 1000][untouched])


@pytest.mark.slow
def test_the_node_is_in_the_ros_graph_with_its_readers_and_writers():
    """A participant reading ros_discovery_info as ROS 2's tools do finds the node by name and namespace,
    and among its entities the writer of TOPIC/repaired and the reader of TOPIC that it matched."""
    domain = random.randint(100, 200)
    node = _node(domain, "--depth-scale", "4000", "--node-name", "d2sr_test", "--namespace", "/robot1")
    peer = ros2_peer.Peer(domain)
    reader = ros2_peer.graph(peer.dp)
    try:
        end = time.monotonic() + 30
        while not peer.matched():
            assert time.monotonic() < end, "the node never matched the peer's topics"
            time.sleep(0.05)
        nodes = []
        while time.monotonic() < end and not nodes:
            for s in reader.take(N=16):
                nodes += [n for n in s.node_entities_info_seq if n.node_name == "d2sr_test"]
            time.sleep(0.05)
        (found,) = nodes[:1]
        assert found.node_namespace == "/robot1"
        rep = peer.readers["repaired"]
        writer = rep.get_matched_publication_data(rep.get_matched_publications()[0]).key.bytes
        image_reader = peer.writer.get_matched_subscription_data(
            peer.writer.get_matched_subscriptions()[0]
        ).key.bytes
        assert writer + bytes(8) in [bytes(g.data) for g in found.writer_gid_seq]
        assert image_reader + bytes(8) in [bytes(g.data) for g in found.reader_gid_seq]
    finally:
        node.send_signal(signal.SIGINT)
        node.communicate(timeout=30)
    assert node.returncode == 0


def test_graph_bytes_are_rosbags_bytes():
    from d2sr.ros2.msgs import Gid, NodeEntitiesInfo, ParticipantEntitiesInfo

    ts = get_typestore(Stores.ROS2_HUMBLE)
    t = ts.types
    g = list(range(24))
    ours = ParticipantEntitiesInfo(Gid(g), [NodeEntitiesInfo("/", "d2sr", [Gid(g)], [Gid(g), Gid(g)])])
    gid = t["rmw_dds_common/msg/Gid"](np.array(g, np.uint8))
    theirs = t["rmw_dds_common/msg/ParticipantEntitiesInfo"](
        gid, [t["rmw_dds_common/msg/NodeEntitiesInfo"]("/", "d2sr", [gid], [gid, gid])]
    )
    assert ours.serialize() == bytes(ts.serialize_cdr(theirs, "rmw_dds_common/msg/ParticipantEntitiesInfo"))


def test_a_relative_topic_resolves_under_the_node_s_namespace():
    from d2sr.ros2 import Ros2Node, Wire

    node = Ros2Node("camera/depth", 4000.0, Wire(domain=random.randint(100, 200), namespace="/robot1"))
    try:
        assert node.topics == ["/robot1/camera/depth"]
    finally:
        node.close()
    for bad in ("robot1", "/robot 1", "/robot1/"):
        with pytest.raises(ConfigError, match="namespace"):
            Ros2Node("camera/depth", 4000.0, Wire(domain=150, namespace=bad))


@pytest.mark.slow
def test_three_cameras_in_one_process_each_get_every_frame_back_and_their_own_diagnostics():
    """``--topic`` three times: one loop per camera, the models shared; at 15 Hz each with every other frame
    interfered, each camera's frames come back with their stamps or are counted as dropped (a busy CI
    machine may fall behind: that every frame comes back is a rate, measured by ``lab.ros2_loopback
    --cameras 3``), and ``/diagnostics`` holds a status per camera."""
    from d2sr.sim.interference import corrupt

    domain = random.randint(100, 200)
    topics = [f"/cam{i}/depth/image_rect_raw" for i in range(3)]
    args = [a for t in topics for a in ("--topic", t)]
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    node = subprocess.Popen([sys.executable, "-m", "d2sr", "ros2", *args, "--depth-scale", "4000"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    peers = [ros2_peer.Peer(domain, t, diagnostics=i == 0) for i, t in enumerate(topics)]
    n = 20
    frames = []
    for k in range(n):
        f = room(k, (240, 320))
        if k % 2:
            where = np.zeros(f.shape, bool)
            where[80:130, :] = True
            f = corrupt(f, 4000.0, where, np.random.default_rng(k))[0]
        frames.append(f)
    got: list[dict[str, list]] = [{"repaired": [], "diagnostics": []} for _ in peers]
    try:
        end = time.monotonic() + 60
        while not all(p.matched() for p in peers):
            assert time.monotonic() < end, "the node never matched the peers' topics"
            time.sleep(0.05)
        for k, f in enumerate(frames):
            for p in peers:
                p.writer.write(ros2_peer.image(f, 1000 + k, 500))
            time.sleep(1 / 15)
        end = time.monotonic() + 20
        while time.monotonic() < end and min(len(g["repaired"]) for g in got) < n:
            for p, g in zip(peers, got, strict=True):
                for key, new in p.take().items():
                    if key in g:
                        g[key] += new
            time.sleep(0.05)

        def settled(st: Any) -> bool:  # every frame of the camera out or dropped
            v = {kv.key: kv.value for kv in st.values}
            return int(v["frames_out"]) + int(v["dropped"]) == n

        def all_out() -> bool:  # a /diagnostics written after every camera's last frame
            return any(all(settled(st) for st in d.status) for d in got[0]["diagnostics"])

        _collect(peers[0], got[0], all_out, seconds=5)
    finally:
        node.send_signal(signal.SIGINT)
        out, err = node.communicate(timeout=30)
    assert node.returncode == 0, err
    last = got[0]["diagnostics"][-1]
    assert sorted(s.hardware_id for s in last.status) == topics
    assert all_out()
    text = " ".join(out.split())
    for t, g, s in zip(topics, got, sorted(last.status, key=lambda s: s.hardware_id), strict=True):
        values = {kv.key: kv.value for kv in s.values}
        back = sorted(m.header.stamp.sec for m in g["repaired"])
        assert len(set(back)) == len(back) and set(back) <= set(range(1000, 1000 + n))  # own stamps, once
        dropped = int(values["dropped"])
        assert values["frames_in"] == str(n) and values["frames_out"] == str(n - dropped)
        assert len(back) == n - dropped >= n // 2  # what was not dropped came back; no camera starved
        assert f"{t}: {n} frames in, {n - dropped} out" in text, out


def test_remapping_renames_topics_node_and_namespace_as_ros_args_do():
    from d2sr.ros2 import Wire

    w = Wire(namespace="/robot1", remaps=("camera/depth/repaired:=/clean/depth", "__node:=fixer"))
    assert w.resolve("camera/depth") == "/robot1/camera/depth"
    assert w.resolve("/robot1/camera/depth/repaired") == "/clean/depth"
    assert w.resolve("camera/depth/repaired") == "/clean/depth"
    assert w.name == "fixer" and w.space == "/robot1"
    assert Wire(remaps=("__ns:=/r2",)).resolve("depth") == "/r2/depth"
    for bad in ("depth", "a:=", ":=b", "a b:=c", "__node:=9x", "__ns:=r2"):
        with pytest.raises(ConfigError, match=r"remap|node name|namespace") as err:
            Wire(remaps=(bad,))
        assert err.value.setting in ("remap", "node_name", "namespace")  # the CLI names its flag


def test_several_cameras_are_checked_before_dds_starts():
    from d2sr.ros2 import Camera, Ros2Node, Wire

    w = Wire(domain=random.randint(100, 200))
    with pytest.raises(ConfigError, match="named twice"):
        Ros2Node(["/a/depth", Camera("/a/depth")], 4000.0, w)
    with pytest.raises(ConfigError, match="one colour topic per topic"):
        Ros2Node(["/a/depth", "/b/depth"], 4000.0, w, colour_topic="/a/colour")
    with pytest.raises(ConfigError, match="1 to 16"):
        Ros2Node([], 4000.0, w)


def test_the_cli_pairs_repeated_options_with_topics_in_order():
    code, _, err = d2sr_inprocess(
        "ros2", "--topic", "/a/depth", "--topic", "/b/depth", "--scene-from", "x.npz", "--seconds", "0.1"
    )
    assert code == 2 and "--scene-from: give one per topic (2)" in err


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.text(max_size=30), max_size=4),
    st.text(max_size=20),
    st.text(max_size=30),
)
def test_any_names_and_rules_give_a_wire_or_one_config_error(remaps, namespace, topic):
    """Whatever names and remapping rules come (a parameters file is data), a Wire is made or refused with
    d2sr's own error; a topic it resolves is a ROS 2 name."""
    from d2sr.ros2 import Wire

    try:
        w = Wire(namespace=namespace or "/", remaps=tuple(remaps))
        name = w.resolve(topic)
    except ConfigError:
        return
    assert name.startswith("/") and dds_topic(name).startswith("rt/")


def test_cameras_take_turns_for_free_workers_and_a_remapped_output_goes_where_the_rule_says():
    """When frames wait on every camera, the free workers go to the cameras in turn, not to the camera
    whose frames were taken first in each pass (which starved the others when behind)."""
    from d2sr.ros2 import Ros2Node, Wire

    w = Wire(domain=random.randint(100, 200), remaps=("/a/depth/repaired:=/clean",))
    node = Ros2Node(["/a/depth", "/b/depth", "/c/depth"], 4000.0, w)
    started: list[int] = []
    try:
        # (one node for two checks, the suite's time) a remapped output is written where the rule says
        cam = node.cameras[0]
        assert (cam.reader.topic.name, cam.repaired.topic.name) == ("rt/a/depth", "rt/clean")
        assert (
            cam.mask.topic.name == "rt/a/depth/mask"
            and node.cameras[1].repaired.topic.name == "rt/b/depth/repaired"
        )
        for i, cam in enumerate(node.cameras):
            cam.waiting.extend((None, i + 0.0001 * k) for k in range(2))  # camera 0 taken first

            def start(cam=cam, i=i) -> None:
                cam.waiting.popleft()
                cam.running.append((None, 0.0, None))  # type: ignore[arg-type]
                started.append(i)

            cam.start_oldest = start  # type: ignore[method-assign]
        node.start_waiting()
        for cam in node.cameras:
            cam.running.clear()
    finally:
        node.close()
    assert len(started) == min(2 * node._workers, 6)
    assert started == [0, 1, 2, 0, 1, 2][: len(started)]
