"""Every reader and the library's entry points, fed what an attacker or a broken disk gives: each call either
succeeds or raises one of d2sr's errors (one line), never another exception, a hang or a huge allocation."""

from __future__ import annotations

import contextlib
import json
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from d2sr.errors import D2SRError
from d2sr.frames import open_frames
from d2sr.frames.encoded import check_encoded
from d2sr.frames.png import decode_png, read_meta
from helpers import room

FUZZ = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _png(w: int, h: int, depth: int = 16, colour: int = 0, body: bytes = b"") -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    head = chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0))
    return b"\x89PNG\r\n\x1a\n" + head + chunk(b"IDAT", zlib.compress(body)) + chunk(b"IEND", b"")


@FUZZ
@given(st.binary(max_size=300))
def test_random_bytes_as_a_png(data):
    for blob in (data, b"\x89PNG\r\n\x1a\n" + data, b"\x89PNG\r\n\x1a\n" + data + b"IEND\xaeB`\x82"):
        with contextlib.suppress(D2SRError):
            decode_png(blob, "f.png")


@FUZZ
@given(
    st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1), st.sampled_from([1, 8, 16]),
    st.sampled_from([0, 2, 4, 6]), st.binary(max_size=64),
)  # fmt: skip
def test_random_png_headers_are_refused_before_decoding(w, h, depth, colour, body):
    try:
        img = decode_png(_png(w, h, depth, colour, body), "f.png")
    except D2SRError:
        return
    assert img.shape == (h, w) and 0 < w * h <= 4096 * 4096


def test_a_png_bomb_is_refused_from_its_header():
    import resource

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    bomb = _png(20000, 20000, 16, 0, bytes(1 << 16))
    with pytest.raises(D2SRError, match="20000x20000"):
        decode_png(bomb, "bomb.png")
    with pytest.raises(D2SRError):
        check_encoded(_png(65535, 65535), "big.png")
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # KB: nothing allocated


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=12,
)
_META = st.fixed_dictionaries(
    {},
    optional={
        "depth_scale": _JSON,
        "intrinsics": _JSON
        | st.fixed_dictionaries({k: _JSON for k in ("fx", "fy", "px", "py", "width", "height")}),
        "frames": _JSON | st.lists(st.fixed_dictionaries({"name": _JSON, "timestamp_ns": _JSON}), max_size=3),
    },
)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("meta")
    for i in range(3):
        cv2.imwrite(str(root / f"{i:06d}.png"), room(i, (48, 64)))
    return root


@FUZZ
@given(_META)
def test_random_meta_json(folder, meta):
    (folder / "meta.json").write_text(json.dumps(meta))
    try:
        read_meta(folder)
        reader = open_frames(folder)
        for f in reader:
            assert f.depth.shape == (48, 64)
            assert f.timestamp_ns is None or isinstance(f.timestamp_ns, int)
    except D2SRError:
        pass


@FUZZ
@given(st.binary(max_size=200))
def test_random_bytes_as_meta_json(folder, data):
    (folder / "meta.json").write_bytes(data)
    with contextlib.suppress(D2SRError):
        read_meta(folder)


_NAMES = st.lists(
    st.text(max_size=12) | st.sampled_from(["..", ".", "../x", "a/b", "a\x00", "x" * 300]),
    min_size=1,
    max_size=4,
)


@FUZZ
@given(_NAMES, st.sampled_from(["<u2", "<f4", "<i8", "<f8", "|u1"]), st.integers(0, 3))
def test_random_npz_names_and_arrays(tmp_path, names, dtype, ndim_off):
    from d2sr.frames.npz import NpzReader

    n = len(names)
    shape = (n, 6, 8)[: 3 - (ndim_off % 3)] if ndim_off else (n, 6, 8)
    path = tmp_path / "rec.npz"
    np.savez(path, depth=np.ones(shape, dtype), names=np.array(names))
    try:
        reader = NpzReader(path)
    except D2SRError:
        return
    got = [f.name for f in reader]
    assert len(set(got)) == len(got) == len(reader)  # no frame is lost to a name twice
    assert all("/" not in g and g not in (".", "..") for g in got)


def test_npz_names_that_repeat_or_climb_are_refused(tmp_path):
    from d2sr.frames.npz import NpzReader

    for names in (["a", "a"], ["../x", "b"], ["", "b"]):
        np.savez(tmp_path / "r.npz", depth=np.ones((2, 6, 8), np.uint16), names=np.array(names))
        with pytest.raises(D2SRError):
            NpzReader(tmp_path / "r.npz")


def _array(shape: tuple[int, ...], dtype: object, fill: float) -> object:
    if dtype == "list":
        return [[1, 2]]
    with np.errstate(all="ignore"):
        return np.full(shape, fill, np.float64).astype(dtype)


_ARRAYS = st.builds(
    _array,
    st.tuples(st.integers(0, 40), st.integers(0, 40))
    | st.tuples(st.integers(1, 3), st.integers(1, 3), st.integers(1, 3)),
    st.sampled_from([np.uint16, np.float32, np.float64, np.int32, np.uint8, np.bool_, "list"]),
    st.sampled_from([0, 1, 2000, 65535, np.nan, np.inf, -1.0]),
)
_VALUE = st.none() | st.booleans() | st.integers(-3, 9) | st.floats() | st.text(max_size=4)


@FUZZ
@given(
    _ARRAYS,
    st.fixed_dictionaries(
        {},
        optional={
            "depth_scale": _VALUE, "threshold": _VALUE, "mask_logit": _VALUE, "passes": _VALUE,
            "repair": st.sampled_from(["all", "none", "flagged", "x"]) | _VALUE,
            "model": st.just("nope") | _VALUE,
        },
    ),
)  # fmt: skip
def test_the_api_on_random_arrays_and_options(weights, depth, options):
    import warnings

    import d2sr

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = d2sr.repair(depth, **({"models": weights, "model": "unet8"} | options))
        except D2SRError:
            return
    assert r.depth.shape == np.asarray(depth).shape and r.mask.shape == r.depth.shape


@FUZZ
@given(st.binary(max_size=400), st.sampled_from(["rec.bag", "rec.npz", "rec.mcap", "rec.db3", "bag2"]))
def test_random_bytes_as_any_recording(tmp_path, data, name):
    path = tmp_path / name
    if name == "bag2":  # a ROS 2 bag folder whose metadata is noise
        path.mkdir(exist_ok=True)
        (path / "metadata.yaml").write_bytes(data)
        (path / "bag2_0.mcap").write_bytes(data[::-1])
    else:
        path.write_bytes(data)
    try:
        with open_frames(path) as reader:
            for f in reader:
                assert f.depth.ndim == 2
    except D2SRError:
        pass


def test_a_bag_whose_depth_message_has_no_width_is_one_line(tmp_path, weights):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    bag = tmp_path / "bag"
    with Writer(bag, version=9) as w:
        conn = w.add_connection("/camera/depth", "sensor_msgs/msg/Image", typestore=ts)
        for i, (h, wd) in enumerate([(48, 64), (48, 0), (48, 64)]):
            depth = room(i, (48, 64), 1000.0)[:h, :wd]
            msg = T["sensor_msgs/msg/Image"](
                header=T["std_msgs/msg/Header"](
                    stamp=T["builtin_interfaces/msg/Time"](sec=i, nanosec=0), frame_id="c"
                ),
                height=h, width=wd, encoding="16UC1", is_bigendian=0, step=wd * 2,
                data=np.ascontiguousarray(depth).view(np.uint8).reshape(-1),
            )  # fmt: skip
            w.write(conn, i * 10**9, ts.serialize_cdr(msg, "sensor_msgs/msg/Image"))
    from helpers import d2sr_inprocess

    models = ["--models", str(weights)]
    for cmd in (["recover", *models], ["detect", *models], ["fill", "--active-frames", "2"]):
        out = tmp_path / f"out-{cmd[0]}{'.csv' if cmd[0] == 'detect' else ''}"
        code, _, err = d2sr_inprocess(cmd[0], str(bag), "--out", str(out), *cmd[1:])
        assert code == 2 and "no pixels" in err and len(err.strip().splitlines()) == 1, (cmd, err)
        assert not out.exists() and not list(tmp_path.glob(f".{out.name}*"))


# What the readers and the API must take: a reader that refused everything would pass the tests above.


@FUZZ
@given(st.integers(1, 48), st.integers(1, 48), st.integers(0, 2**31 - 1))
def test_any_valid_depth_png_is_taken_as_written(h, w, seed):
    from d2sr.frames.png import encode_png

    img = np.random.default_rng(seed).integers(0, 65536, (h, w), dtype=np.uint16)
    assert np.array_equal(decode_png(encode_png(img, "f.png"), "f.png"), img)


@FUZZ
@given(st.floats(0.5, 1e5, allow_nan=False), st.lists(st.integers(0, 2**62), min_size=3, max_size=3))
def test_any_valid_meta_json_is_taken(folder, scale, stamps):
    from d2sr.frames.png import write_meta

    names = sorted(p.stem for p in folder.glob("*.png"))
    write_meta(
        folder, scale, None, [{"name": n, "timestamp_ns": t} for n, t in zip(names, stamps, strict=True)]
    )
    assert read_meta(folder)["depth_scale"] == scale
    with open_frames(folder) as reader:
        assert [f.timestamp_ns for f in reader] == stamps


@FUZZ
@given(st.lists(st.text("abcXYZ019_-.", min_size=1, max_size=10), min_size=1, max_size=4, unique=True))
def test_any_valid_npz_names_are_taken_in_order(tmp_path, names):
    from d2sr.frames.npz import NpzReader

    if any(n in (".", "..") for n in names):
        return  # names that climb are refused (test_npz_names_that_repeat_or_climb_are_refused)
    path = tmp_path / "rec.npz"
    np.savez(path, depth=np.ones((len(names), 6, 8), np.uint16), names=np.array(names))
    assert [f.name for f in NpzReader(path)] == names


@FUZZ
@given(
    st.integers(24, 80), st.integers(24, 120), st.integers(0, 2**31 - 1), st.sampled_from(["all", "flagged"])
)
def test_the_api_takes_any_valid_frame(weights, h, w, seed, repair):
    import warnings

    import d2sr

    depth = np.random.default_rng(seed).integers(0, 20000, (h, w), dtype=np.uint16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # doubts about an odd frame's scale are warnings, not errors
        r = d2sr.repair(depth, depth_scale=4000, models=weights, model="unet8", repair=repair)
    assert r.depth.dtype == np.uint16 and r.depth.shape == (h, w)
    assert np.array_equal(r.depth[~r.mask], depth[~r.mask])  # every pixel outside the mask as it came
