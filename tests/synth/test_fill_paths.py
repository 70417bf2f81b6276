"""Synthesis on the loop's other paths: which colour frames the laser skipped (``d2sr.synth.gaps``), a bag's
colour stream through ``d2sr run BAG --fill --colour-topic``, and a live camera's through ``run_live``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_typestore

from d2sr.frames.base import Frame
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.synth.gaps import ColourFrame, ColourGaps, interleave
from helpers import K, colour_of_wall, d2sr_inprocess, texture

DEPTH, COLOUR = "/camera/depth/image_raw", "/camera/color/image_raw"
STEP = 33_333_333  # ns between slots
SLOTS = 45  # a period and a half, the laser on in slots 0-5 of every 30
T0 = 10**9


def _on(k: int) -> bool:
    return k % 30 < 6


def _mm(k: int) -> int:
    """How far the wall is in slot ``k``: the camera walks 15 mm a slot towards it from 3 m."""
    return 3000 - 15 * k


def _follows(depth_mm: float, k: int) -> bool:
    """A synthesized slot ``k``'s depth follows the camera: within a quarter of what holding the last real
    frame would be off by (chained colour motion drifts a little), and 1 cm."""
    real = max(j for j in range(k + 1) if _on(j))
    return abs(depth_mm - _mm(k)) <= 0.25 * abs(_mm(real) - _mm(k)) + 10


def _walls_and_colours() -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each slot's depth of a textured wall (mm) and its colour, the camera walking towards the wall: a
    frame held from the last real one is off by up to 36 cm, one that follows the colour is not."""
    tex = texture(3)
    walls = [np.full((K.height, K.width), _mm(k), np.uint16) for k in range(SLOTS)]
    return walls, [colour_of_wall(np.array([0.0, 0.0, 0.015 * k]), tex) for k in range(SLOTS)]


def test_every_colour_frame_without_depth_is_a_skipped_slot_in_time_order():
    """The frame just before each window is one too: no depth frame joins it once the window's first came."""
    depths = [Frame(f"{k:03d}", np.zeros((2, 2), np.uint16), T0 + k * STEP) for k in range(SLOTS) if _on(k)]
    # colour stamps a few ms off the depth's, as two sensors' clocks give them; one colour frame lost (7)
    colours = [(T0 + k * STEP + 3_000_000, np.full((2, 2), k, np.uint8)) for k in range(SLOTS) if k != 7]
    out = list(interleave(depths, colours))
    assert [int(f.name) for f, _, _ in out if f is not None] == [k for k in range(SLOTS) if _on(k)]
    skipped = [int(c[0, 0]) for f, c, _ in out if f is None]
    assert skipped == [k for k in range(SLOTS) if not _on(k) and k != 7]  # 29 included
    joined = [(int(f.name), None if c is None else int(c[0, 0])) for f, c, _ in out if f is not None]
    assert all(k == c for k, c in joined)  # each depth frame got its own colour frame
    stamps = [t for _, _, t in out]
    assert stamps == sorted(stamps)


def test_colour_gaps_wait_for_the_depth_frame_then_come_due():
    gaps = ColourGaps(wait_s=0.1)
    img = np.zeros((2, 2), np.uint8)
    gaps.colour(ColourFrame(T0, img, 5.0))
    gaps.colour(ColourFrame(T0 + STEP, img, 5.03))
    assert gaps.due(5.05) == []  # still waiting for its depth frame
    # the older one can no longer be joined
    assert [c.stamp for c in gaps.depth(T0 + STEP + 2_000_000)] == [T0]
    assert gaps.due(5.2) == []  # the newer one was joined
    gaps.real(T0 + 2 * STEP)
    gaps.colour(ColourFrame(T0 + STEP // 2, img, 5.3))  # older than synthesis's source: never made
    assert gaps.flush() == []


def test_a_colour_frame_whose_depth_frame_arrived_but_waits_for_a_worker_never_comes_due():
    """A busy node queues a depth frame before pairing it: its colour frame must not be synthesized meanwhile
    (a loaded CI machine published a synthesized frame for a slot the laser lit)."""
    gaps = ColourGaps(wait_s=0.1)
    img = np.zeros((2, 2), np.uint8)
    gaps.colour(ColourFrame(T0, img, 5.0))
    gaps.colour(ColourFrame(T0 + STEP, img, 5.03))
    gaps.coming(T0 + 1_000_000)
    assert [c.stamp for c in gaps.due(5.5)] == [T0 + STEP]  # only the one no depth frame came for
    assert gaps.depth(T0 + 1_000_000) == []


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.booleans(), st.floats(0, 0.3), st.floats(0, 0.3), st.floats(0, 0.3)),
        min_size=1,
        max_size=40,
    )
)
def test_colour_gaps_never_synthesize_a_slot_whose_depth_frame_arrived_and_miss_none_that_had_none(slots):
    """Any timing a busy host gives: slot k's colour frame comes at k/30 s + a delay, its depth frame (when
    the laser was on) reaches the host at k/30 s + another and is paired (``depth``) later still, each
    stream in its own order; ``due`` is asked at every event. A colour frame comes out at most once, never
    once its depth frame has arrived, and every slot with no depth frame comes out unless a later depth frame
    was paired before its colour frame arrived."""
    gaps = ColourGaps(wait_s=0.1)
    img = np.zeros((2, 2), np.uint8)
    events = []  # (time, order, kind, slot)
    colour_at = arrived = paired_at = 0.0  # each stream arrives in its own order; depth is paired in order
    for k, (lit, colour_delay, depth_delay, busy) in enumerate(slots):
        colour_at = max(colour_at, k / 30 + colour_delay)
        events.append((colour_at, 1, "colour", k))
        if lit:
            arrived = max(arrived, k / 30 + depth_delay)
            paired_at = max(paired_at, arrived + busy)
            events += [(arrived, 0, "coming", k), (paired_at, 2, "depth", k)]
    events.sort()
    out: list[tuple[int, int]] = []  # slot, the event after which it came out
    for i, (t, _, kind, k) in enumerate(events):
        stamp = T0 + k * STEP
        if kind == "colour":
            gaps.colour(ColourFrame(stamp, img, t))
        elif kind == "coming":
            gaps.coming(stamp)
        else:
            out += [((c.stamp - T0) // STEP, i) for c in gaps.depth(stamp)]
            gaps.real(stamp)
        out += [((c.stamp - T0) // STEP, i) for c in gaps.due(t)]
    out += [((c.stamp - T0) // STEP, len(events)) for c in gaps.flush()]
    came = [k for k, _ in out]
    assert len(came) == len(set(came))  # at most once
    arrival = {k: i for i, (_, _, kind, k) in enumerate(events) if kind == "coming"}
    coloured = {k: t for t, _, kind, k in events if kind == "colour"}
    for k, i in out:
        assert k not in arrival or arrival[k] > i  # never once its depth frame arrived
    paired = [(t, k) for t, _, kind, k in events if kind == "depth"]
    for k in range(len(slots)):
        later_first = any(j > k and t <= coloured[k] for t, j in paired)
        if k not in arrival and not later_first:
            assert k in came


def _bag(path: Path, colour: bool = True) -> None:
    """A ROS 2 bag of a duty-cycled camera: colour (bgr8) every slot, depth (16UC1, mm, aligned to colour)
    only in the window, the camera's intrinsics."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    walls, colours = _walls_and_colours()
    with Writer(path, version=9) as bag:
        dc = bag.add_connection(DEPTH, "sensor_msgs/msg/Image", typestore=ts)
        cc = bag.add_connection(COLOUR, "sensor_msgs/msg/Image", typestore=ts)
        ic = bag.add_connection("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)

        def header(ns: int) -> object:
            t = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            return T["std_msgs/msg/Header"](stamp=t, frame_id="camera")

        k9 = np.array([K.fx, 0, K.px, 0, K.fy, K.py, 0, 0, 1], np.float64)
        roi = T["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False)
        info = T["sensor_msgs/msg/CameraInfo"](
            header(T0), K.height, K.width, "plumb_bob", np.zeros(5), k9, np.eye(3).ravel(), np.zeros(12),
            0, 0, roi,
        )  # fmt: skip
        bag.write(ic, T0, ts.serialize_cdr(info, "sensor_msgs/msg/CameraInfo"))
        for k in range(SLOTS):
            ns = T0 + k * STEP
            if colour:
                img = cv2.cvtColor(colours[k], cv2.COLOR_GRAY2BGR)
                m = T["sensor_msgs/msg/Image"](
                    header(ns), K.height, K.width, "bgr8", 0, K.width * 3, img.reshape(-1)
                )
                bag.write(cc, ns, ts.serialize_cdr(m, "sensor_msgs/msg/Image"))
            if _on(k):
                data = np.frombuffer(walls[k].tobytes(), np.uint8)
                m = T["sensor_msgs/msg/Image"](header(ns), K.height, K.width, "16UC1", 0, K.width * 2, data)
                bag.write(dc, ns + 1000, ts.serialize_cdr(m, "sensor_msgs/msg/Image"))


def _log(run: Path) -> list[dict[str, str]]:
    return list(csv.DictReader((run / "log.csv").open()))


def test_run_on_a_bag_fills_every_slot_its_laser_skipped(tmp_path, weights):
    """``d2sr run BAG --fill --colour-topic``: each colour frame with no depth frame comes back synthesized,
    following the camera from colour, after the real frame it was made from; the real frames and their
    verdicts are those of the same run without --fill."""
    _bag(tmp_path / "bag")
    args = ["run", str(tmp_path / "bag"), "--topic", DEPTH, "--models", str(weights)]
    code, _, err = d2sr_inprocess(*args, "--out", str(tmp_path / "plain"))
    assert code == 0, err
    code, out, err = d2sr_inprocess(
        *args, "--out", str(tmp_path / "filled"), "--fill", "--colour-topic", COLOUR
    )
    assert code == 0 and f"per sensor: {SLOTS - 12}" in out, err
    plain, filled = _log(tmp_path / "plain"), _log(tmp_path / "filled")
    real = [r for r in filled if r["synthesized"] == "0"]
    synth = [r for r in filled if r["synthesized"] == "1"]
    assert len(real) == 12 and len(synth) == SLOTS - 12
    keep = ("frame", "period", "offset", "score", "flagged")
    assert [{k: r[k] for k in keep} for r in real] == [{k: r[k] for k in keep} for r in plain]
    assert [r["frame"] for r in filled] == sorted(r["frame"] for r in filled)  # each after its source
    assert (
        synth[0]["frame"] == "000005_01"
        and synth[23]["frame"] == "000005_24"
        and synth[-1]["frame"] == "000011_09"
    )
    stamps = [round((float(r["time_s"]) - 1.0) * 1e9 / STEP) for r in synth]
    assert stamps == [k for k in range(SLOTS) if not _on(k)]
    depth_dir, conf_dir = (
        tmp_path / "filled" / "sensor0" / "depth",
        tmp_path / "filled" / "sensor0" / "confidence",
    )
    for r, k in zip(synth, stamps, strict=True):  # each where the camera was: not held
        d = cv2.imread(str(depth_dir / f"{r['frame']}.png"), cv2.IMREAD_UNCHANGED)
        c = cv2.imread(str(conf_dir / f"{r['frame']}.png"), cv2.IMREAD_UNCHANGED)
        sure = c == 255
        assert sure.mean() > 0.5 and _follows(np.median(d[sure]), k)
    summary = json.loads((tmp_path / "filled" / "summary.json").read_text())
    assert summary["synthesized"] == [SLOTS - 12]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--fill"], "--colour-topic"),
        (["--fill", "--colour-topic", "/camera/nope"], "no colour topic"),
        (["--fill", "--colour-topic", DEPTH + "_info"], "no colour topic"),
        (["--colour-topic", COLOUR], "--fill"),
    ],
)
def test_run_fill_on_a_recording_refuses_what_it_cannot_use(tmp_path, extra, message):
    _bag(tmp_path / "bag")
    code, _, err = d2sr_inprocess(
        "run", str(tmp_path / "bag"), "--topic", DEPTH, "--out", str(tmp_path / "o"), *extra
    )
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_live_run_fills_what_the_camera_sent_as_colour_alone(tmp_path, monkeypatch, weights):
    """``run_live(fill=True)`` with a camera whose laser is on in slots 0-5: every colour-only moment is
    written synthesized into the run, the real ones as they came."""
    from d2sr.jobs import live
    from d2sr.runtime.pipeline import open_models

    walls, colours = _walls_and_colours()

    def shots(seconds):
        for k in range(SLOTS):
            ns = T0 + k * STEP
            frame = Frame(f"{k:08d}", walls[k].copy(), ns) if _on(k) else None
            yield live.Shot(frame, 1000.0, ns / 1e9, colours[k], ns)

    monkeypatch.setattr(live, "_camera", lambda kind, serial, seconds, *_: (shots(seconds), K))
    net = open_models(RunSettings(models=weights))
    plan = LoopSettings(controller="robust", seconds=2.0, fill=True)
    summary = live.run_live(net, tmp_path / "run", "realsense", RunSettings(), plan)
    rows = _log(tmp_path / "run")
    synth = [r for r in rows if r["synthesized"] == "1"]
    assert summary["synthesized"] == [len(synth)] == [SLOTS - 12]
    assert summary["all"]["frames"] == 12
    assert synth[0]["frame"] == "00000005_01" and all(r["slot"] == "n/a" for r in synth)
    d = cv2.imread(
        str(tmp_path / "run" / "sensor0" / "depth" / f"{synth[-1]['frame']}.png"), cv2.IMREAD_UNCHANGED
    )
    assert _follows(np.median(d[d > 0]), SLOTS - 1)


def test_a_realsense_gives_every_moment_its_depth_aligned_to_colour_or_colour_alone():
    """``shots.rgbd_shots`` on a pyrealsense2 software_device: depth only in slots 0-5 of every 30, colour in
    every slot, both in real time. Each depth frame comes joined with its own colour frame and aligned to
    it; each other colour frame comes alone, in time order (a pipeline's syncer dropped the 8 after each
    window)."""
    import threading
    import time

    from d2sr.frames.realsense import import_rs
    from d2sr.jobs.shots import rgbd_shots

    rs = import_rs()
    dev = rs.software_device()
    ds, cs = dev.add_sensor("Depth"), dev.add_sensor("Color")
    profiles = []
    for sensor, stream, fmt, bpp, uid in ((ds, rs.stream.depth, rs.format.z16, 2, 0),
                                          (cs, rs.stream.color, rs.format.bgr8, 3, 1)):  # fmt: skip
        intr = rs.intrinsics()
        intr.width, intr.height, intr.fx, intr.fy, intr.ppx, intr.ppy = (
            K.width,
            K.height,
            K.fx,
            K.fy,
            K.px,
            K.py,
        )
        vs = rs.video_stream()
        vs.type, vs.fmt, vs.index, vs.uid, vs.width, vs.height, vs.fps, vs.bpp = (
            stream, fmt, 0, uid, K.width, K.height, 30, bpp,
        )  # fmt: skip
        vs.intrinsics = intr
        profiles.append(sensor.add_video_stream(vs))
    ds.add_read_only_option(rs.option.depth_units, 0.001)
    same = rs.extrinsics()
    same.rotation, same.translation = [1, 0, 0, 0, 1, 0, 0, 0, 1], [0, 0, 0]
    profiles[0].register_extrinsics_to(profiles[1], same)
    walls, colours = _walls_and_colours()
    n = 40

    def camera() -> None:
        time.sleep(0.2)
        t0 = time.monotonic()
        for k in range(n):
            bgr = cv2.cvtColor(colours[k], cv2.COLOR_GRAY2BGR)
            for sensor, profile, pixels, bpp, on in ((ds, profiles[0], walls[k], 2, _on(k)),
                                                     (cs, profiles[1], bgr, 3, True)):  # fmt: skip
                if not on:
                    continue
                f = rs.software_video_frame()
                f.pixels, f.stride, f.bpp, f.timestamp, f.frame_number = (
                    pixels,
                    K.width * bpp,
                    bpp,
                    k * 33.3,
                    k,
                )
                f.domain, f.profile = rs.timestamp_domain.hardware_clock, profile.as_video_stream_profile()
                sensor.on_video_frame(f)
            time.sleep(max(0.0, t0 + (k + 1) / 30 - time.monotonic()))

    shots, intrinsics = rgbd_shots(ds.as_depth_sensor(), cs, 2.5)
    assert (intrinsics.width, intrinsics.fx) == (K.width, K.fx)
    feeder = threading.Thread(target=camera)
    feeder.start()
    got = list(shots)
    feeder.join()
    slots = [round(s.stamp / 33.3e6) for s in got]
    assert slots == list(range(n))  # every moment once, in time order
    for k, s in zip(slots, got, strict=True):
        assert s.colour is not None and np.array_equal(s.colour[..., 0], colours[k])
        assert (s.depth is not None) == _on(k)
        if s.depth is not None:
            assert s.scale == pytest.approx(1000.0) and np.median(s.depth.depth) == _mm(k)


def test_recover_a_bag_with_its_colour_topic_gives_every_slot_a_depth_frame(tmp_path, weights):
    """``d2sr recover BAG --colour-topic``: the bag back with every input message, a repaired frame and mask
    for each depth message, and for each colour message no depth message joins a synthesized frame on
    T/repaired (its stamp, 16UC1, following the camera) with an empty T/mask and its T/confidence: what
    ``d2sr ros2 --colour-topic`` publishes."""
    from rosbags.highlevel import AnyReader

    _bag(tmp_path / "bag")
    out = tmp_path / "out"
    code, stdout, err = d2sr_inprocess("recover", str(tmp_path / "bag"), "--topic", DEPTH, "--colour-topic",
                                       COLOUR, "--models", str(weights), "--out", str(out))  # fmt: skip
    assert code == 0 and f"{SLOTS - 12} synthesized for colour frames" in stdout, err
    got: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([out]) as r:
        for conn, _, raw in r.messages():
            got.setdefault(conn.topic, []).append(r.deserialize(raw, conn.msgtype))
    assert len(got[DEPTH]) == 12 and len(got[COLOUR]) == SLOTS  # the input, copied
    slot = [
        round((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - T0) / STEP)
        for m in got[DEPTH + "/repaired"]
    ]
    assert slot == list(range(SLOTS))  # every moment once, in time order
    assert len(got[DEPTH + "/mask"]) == SLOTS and len(got[DEPTH + "/confidence"]) == SLOTS - 12
    for rep in got[DEPTH + "/repaired"]:
        k = round((rep.header.stamp.sec * 10**9 + rep.header.stamp.nanosec - T0) / STEP)
        d = np.frombuffer(bytes(rep.data), np.uint16).reshape(K.height, K.width)
        assert rep.encoding == "16UC1" and _follows(np.median(d[d > 0]), k)
        if not _on(k):
            assert not np.frombuffer(bytes(got[DEPTH + "/mask"][k].data), np.uint8).any()
    conf = np.frombuffer(bytes(got[DEPTH + "/confidence"][-1].data), np.uint8)
    assert (conf == 255).mean() > 0.5
    args = ["recover", str(tmp_path / "bag"), "--topic", DEPTH, "--colour-topic", COLOUR, "--format", "png"]
    code, _, err = d2sr_inprocess(*args, "--out", str(tmp_path / "png"))
    assert code == 2 and "--colour-topic" in err and not (tmp_path / "png").exists()
