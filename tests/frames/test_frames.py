"""Depth I/O: every format round-trips bit-exactly; bad recordings give one-line InputErrors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from d2sr.errors import InputError
from d2sr.frames import Frame, Intrinsics, detect_format, open_frames, open_writer
from d2sr.frames.base import MAX_PIXELS
from d2sr.frames.rosbag import INFO

INTR = Intrinsics(40, 30, 30.5, 30.25, 19.5, 14.75)


def _frames(n: int = 4, dtype: type = np.uint16, shape: tuple[int, int] = (30, 40)) -> list[Frame]:
    rng = np.random.default_rng(0)
    out = []
    for i in range(n):
        if dtype == np.uint16:
            d = rng.integers(0, 65535, shape, dtype=np.uint16)
        else:
            d = rng.uniform(0, 9, shape).astype(np.float32)
            d[rng.random(shape) < 0.3] = 0
        out.append(Frame(f"{i:06d}", d, 1_700_000_000_000_000_000 + i * 33_333_000))
    return out


def _roundtrip(path: Path, fmt: str, frames: list[Frame], scale: float, **opt: object) -> list[Frame]:
    with open_writer(path, fmt, scale, INTR, **opt) as w:
        for f in frames:
            w.write(f)
    assert detect_format(path) == fmt
    with open_frames(path) as r:
        got = list(r)
        assert len(r) == len(frames)
        assert r.depth_scale == scale
        assert r.shape == frames[0].depth.shape
    assert len(got) == len(frames)
    for a, b in zip(frames, got, strict=True):
        assert b.depth.dtype == a.depth.dtype
        assert np.array_equal(a.depth, b.depth)
        assert b.timestamp_ns == a.timestamp_ns
    return got


def test_png_roundtrip(tmp_path):
    frames = _frames()
    got = _roundtrip(tmp_path / "rec", "png", frames, 4000.0)
    assert [f.name for f in got] == [f.name for f in frames]
    with open_frames(tmp_path / "rec") as r:
        assert r.intrinsics == INTR


def test_npz_roundtrip_uint16_and_float(tmp_path):
    _roundtrip(tmp_path / "a.npz", "npz", _frames(), 1000.0)
    _roundtrip(tmp_path / "b.npz", "npz", _frames(dtype=np.float32), 1.0)


@pytest.mark.parametrize("compressed", [False, True])
def test_ros1_roundtrip(tmp_path, compressed):
    _roundtrip(tmp_path / "a.bag", "ros1", _frames(), 1000.0, compressed=compressed)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_roundtrip(tmp_path, storage):
    _roundtrip(tmp_path / "bag", "ros2", _frames(), 1000.0, storage=storage)
    _roundtrip(tmp_path / "fbag", "ros2", _frames(dtype=np.float32), 1.0, storage=storage)
    inner = next((tmp_path / "bag").glob("*.db3" if storage == "sqlite3" else "*.mcap"))
    assert len(open_frames(inner)) == 4  # the storage file inside the folder works too


def test_ros2_compressed_depth_roundtrip(tmp_path):
    _roundtrip(tmp_path / "bag", "ros2", _frames(), 1000.0, compressed=True)


def test_realsense_roundtrip(tmp_path):
    # No skip: the dev install brings pyrealsense2 and libusb-package (d2sr[realsense]); a missing one fails.
    frames = _frames(3)
    # RealSense timestamps are double milliseconds: microsecond stamps survive exactly.
    frames = [
        Frame(f.name, f.depth, 1_700_000_000_000_000_000 + i * 33_333_000) for i, f in enumerate(frames)
    ]
    got = _roundtrip(tmp_path / "rec.db3", "realsense", frames, 4000.0)
    with open_frames(tmp_path / "rec.db3") as r:
        assert r.intrinsics is not None and r.intrinsics.width == 40
        assert abs(r.intrinsics.fx - INTR.fx) < 1e-4
    assert len(got) == 3


def test_bag_topic_selection(tmp_path):
    path = tmp_path / "two.bag"
    from rosbags.rosbag1 import Writer as W1

    from d2sr.frames.rosbag import _TS1, _message

    frames = _frames(2)
    with W1(path) as w:
        for topic in ("/a/depth/image", "/b/depth/image"):
            conn = w.add_connection(topic, "sensor_msgs/msg/Image", typestore=_TS1)
            for i, f in enumerate(frames):
                msg, mt = _message(_TS1, f, False, True)
                w.write(conn, i + 1, _TS1.serialize_ros1(msg, mt))
    with pytest.raises(InputError, match="several image topics"):
        open_frames(path)
    with pytest.raises(InputError, match="no topic '/c'"):
        open_frames(path, topic="/c")
    assert len(list(open_frames(path, topic="/b/depth/image"))) == 2


def test_bag_without_depth_topic(tmp_path):
    from rosbags.rosbag1 import Writer as W1

    from d2sr.frames.rosbag import _TS1

    path = tmp_path / "chatter.bag"
    with W1(path) as w:
        conn = w.add_connection("/chatter", "std_msgs/msg/String", typestore=_TS1)
        w.write(
            conn, 1, _TS1.serialize_ros1(_TS1.types["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String")
        )
    with pytest.raises(InputError, match="no depth topic"):
        open_frames(path)


def test_writer_leaves_nothing_on_error(tmp_path):
    frames = _frames(2)
    for fmt, name in (("png", "rec"), ("npz", "a.npz"), ("ros1", "a.bag"), ("ros2", "bag")):
        with pytest.raises(InputError), open_writer(tmp_path / name, fmt, 1000.0) as w:
            w.write(frames[0])
            w.write(Frame("bad", np.zeros((5, 5), np.uint16)))  # a different size
        assert not (tmp_path / name).exists(), fmt
    assert list(tmp_path.iterdir()) == []


def test_rewrite_replaces_old_output(tmp_path):
    out = tmp_path / "rec"
    for n in (3, 2):
        with open_writer(out, "png", 1000.0) as w:
            for f in _frames(n):
                w.write(f)
    assert len(open_frames(out)) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"]


def _intrinsics(folder: Path, **bad: float) -> None:
    """A meta.json whose intrinsics have the ``bad`` values (the rest a plausible 40x30 camera's)."""
    k = {"width": 40, "height": 30, "fx": 30.0, "fy": 30.0, "px": 19.5, "py": 14.5, **bad}
    (folder / "meta.json").write_text(json.dumps({"depth_scale": 1000, "intrinsics": k}))


def _png_folder(tmp_path: Path, n: int = 3) -> Path:
    d = tmp_path / "in"
    d.mkdir()
    for f in _frames(n):
        cv2.imwrite(str(d / f"{f.name}.png"), f.depth)
    return d


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda d: (d / "000001.png").write_bytes((d / "000001.png").read_bytes()[:300]), "truncated PNG"),
        (
            lambda d: (d / "000001.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"x" * 200 + b"IEND\xaeB`\x82"),
            "corrupt PNG",
        ),
        (lambda d: (d / "000001.png").write_bytes(b"hello"), "not a PNG"),
        (lambda d: cv2.imwrite(str(d / "000001.png"), np.zeros((30, 40), np.uint8)), "8-bit PNG"),
        (lambda d: cv2.imwrite(str(d / "000001.png"), np.zeros((30, 40, 3), np.uint16)), "3 channels"),
        (
            lambda d: cv2.imwrite(str(d / "000001.png"), np.zeros((31, 40), np.uint16)),
            "earlier frames are 40x30",
        ),
        (lambda d: (d / "meta.json").write_text("{"), "not valid JSON"),
        (lambda d: (d / "meta.json").write_text(json.dumps({"depth_scale": -1})), "positive"),
        (lambda d: _intrinsics(d, width=0), "0x30 pixels has no pixels"),  # divided by zero in the fill
        (lambda d: _intrinsics(d, fx=float("nan")), "fx and fy must be finite and positive"),
        (lambda d: _intrinsics(d, fy=-300.0), "fx and fy must be finite and positive"),
        (lambda d: _intrinsics(d, fx=1e400), "fx and fy must be finite"),  # JSON's Infinity
        (lambda d: _intrinsics(d, px=float("inf")), "px and py must be finite"),
        (lambda d: _intrinsics(d, height=10**12), "d2sr takes images up to"),
    ],
)
def test_bad_png_folder(tmp_path, damage, message):
    d = _png_folder(tmp_path)
    damage(d)
    with pytest.raises(InputError, match=message) as err:
        list(open_frames(d))
    assert "\n" not in str(err.value)


def test_empty_and_missing(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no PNG depth frames"):
        open_frames(tmp_path / "empty")
    with pytest.raises(InputError, match="no such file"):
        open_frames(tmp_path / "nope")
    (tmp_path / "x.npz").write_bytes(b"PK\x03\x04garbage")
    with pytest.raises(InputError, match="corrupt or truncated npz"):
        open_frames(tmp_path / "x.npz")
    (tmp_path / "x.bag").write_bytes(b"#ROSBAG V2.0\ngarbage")
    with pytest.raises(InputError, match="cannot read bag"):
        open_frames(tmp_path / "x.bag")


def test_l515_names_carry_timestamps(tmp_path):
    d = tmp_path / "l515"
    d.mkdir()
    cv2.imwrite(str(d / "dev_0_1699685295130.png"), np.ones((4, 4), np.uint16))
    (d / "intrinsics.json").write_text(json.dumps({"depth_scale": 4000.0, **INTR.to_dict()}))
    r = open_frames(d)
    assert r.depth_scale == 4000.0 and r.intrinsics == INTR
    assert next(iter(r)).timestamp_ns == 1699685295130 * 1_000_000


def test_atomic_outputs_get_ordinary_permissions(tmp_path):
    import os
    import stat

    from d2sr.atomic import atomic_dir, atomic_write

    old = os.umask(0o022)
    try:
        atomic_write(tmp_path / "a.txt", "x")
        with atomic_dir(tmp_path / "d") as d:
            (d / "f").write_text("y")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o644
    assert stat.S_IMODE((tmp_path / "d").stat().st_mode) == 0o755


def test_a_wrong_scale_names_every_sensor_scale_that_fits_the_sensor_s_own_first():
    """Raw L515 frames (4000 units per metre) read as millimetres: the error lists 4000 before 5000 (TUM),
    each with the depth it would give, and names the library's arguments, not the command line's flags."""
    from d2sr.errors import InputError
    from d2sr.frames.base import probe

    frames = [Frame(f"{i}", np.full((48, 64), int(2.9 * 4000), np.uint16)) for i in range(3)]
    with pytest.raises(InputError) as err:
        probe(frames, 1000.0)
    text = str(err.value)
    assert text.index("at 4000 (raw L515, 0.25 mm) it would be 2.90 m") < text.index("at 5000 (TUM")
    assert "--" not in text and "max_range" in text and err.value.setting == "depth_scale"


@pytest.mark.parametrize(
    "values",
    [
        (0, 30, 30.0, 30.0, 20.0, 15.0),
        (40, 30, 0.0, 30.0, 20.0, 15.0),
        (40, 30, 30.0, float("nan"), 20.0, 15.0),
        (40, 30, 30.0, 30.0, float("-inf"), 15.0),
        (40.5, 30, 30.0, 30.0, 20.0, 15.0),
        (True, 30, 1.0, 1.0, 0, 0),
        (40, 30, "30", 30.0, 20.0, 15.0),
        (40, 30, 30.0, 30.0, 20.0, 10**400),
    ],
)
def test_intrinsics_no_camera_has_are_one_input_error(values):
    with pytest.raises(InputError, match="intrinsics"):
        Intrinsics(*values)


def test_a_bags_uncalibrated_camera_info_reads_as_none_and_a_damaged_one_as_one_line(tmp_path):
    """ROS's uncalibrated camera sends K all zeros: no intrinsics (the fill guesses them), not an error;
    a camera_info that cannot be decoded is one line naming it."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    t = ts.types
    head = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="c")
    roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    info = t["sensor_msgs/msg/CameraInfo"](
        header=head, height=30, width=40, distortion_model="", d=np.zeros(0), k=np.zeros(9), r=np.zeros(9),
        p=np.zeros(12), binning_x=0, binning_y=0, roi=roi,
    )  # fmt: skip
    depth = _frames(1)[0].depth
    image = t["sensor_msgs/msg/Image"](
        header=head, height=30, width=40, encoding="16UC1", is_bigendian=0, step=80,
        data=depth.view(np.uint8).reshape(-1),
    )  # fmt: skip
    for name, raw_info in (("zeros", ts.serialize_cdr(info, INFO)), ("damaged", b"\x00\x01\x00\x00\x01")):
        bag = tmp_path / name
        with Writer(bag, version=9) as w:
            ci = w.add_connection("/cam/depth/camera_info", INFO, typestore=ts)
            im = w.add_connection("/cam/depth/image_rect_raw", "sensor_msgs/msg/Image", typestore=ts)
            w.write(ci, 1, raw_info)
            w.write(im, 2, ts.serialize_cdr(image, "sensor_msgs/msg/Image"))
        if name == "zeros":
            assert open_frames(bag).intrinsics is None
        else:
            with pytest.raises(InputError, match="camera_info: cannot decode") as err:
                open_frames(bag)
            assert "\n" not in str(err.value)


_VALUE = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.text(max_size=3),
)


@settings(max_examples=300, deadline=None)
@given(st.tuples(_VALUE, _VALUE, _VALUE, _VALUE, _VALUE, _VALUE))
def test_any_values_make_intrinsics_a_camera_could_have_or_one_input_error(values):
    try:
        k = Intrinsics(*values)
    except InputError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 200
        return
    assert 0 < k.width * k.height <= MAX_PIXELS
    assert k.fx > 0 and k.fy > 0 and np.isfinite([k.fx, k.fy, k.px, k.py]).all()
    half = k.scaled(max(k.width // 2, 1), max(k.height // 2, 1))
    assert half.fx > 0 and np.isfinite([half.fx, half.fy, half.px, half.py]).all()
