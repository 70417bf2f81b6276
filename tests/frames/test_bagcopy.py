"""d2sr recover on ROS bags: a bag of the input's kind back, every input message copied, the repaired
depth and mask added with the input's stamps, pixels equal to the PNG path's; its output rules."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from d2sr.frames.png import encode_png
from helpers import BAG_FRAMES as N
from helpers import BAG_TOPIC as TOPIC
from helpers import d2sr_inprocess
from helpers import write_bag as _write_bag


def _read(path: Path) -> dict[str, list[tuple[int, object, bytes]]]:
    got: dict[str, list[tuple[int, object, bytes]]] = {}
    with AnyReader([path]) as r:
        for c, stamp, raw in r.messages():
            got.setdefault(c.topic, []).append((stamp, r.deserialize(raw, c.msgtype), bytes(raw)))
    return got


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_a_bag_in_gives_a_bag_of_its_kind_with_repairs(tmp_path, weights, kind):
    src = tmp_path / ("in.bag" if kind == "ros1" else "in")
    frames = _write_bag(src, kind)
    out = tmp_path / ("out.bag" if kind == "ros1" else "out")
    code, _, err = d2sr_inprocess(
        "recover", str(src), "--repair", "all", "--models", str(weights), "--out", str(out)
    )
    assert code == 0, err
    if kind != "ros1":  # the input's storage kept
        assert any(out.glob("*.mcap" if kind == "mcap" else "*.db3"))
    before, after = _read(src), _read(out)
    assert set(after) == {*before, TOPIC + "/repaired", TOPIC + "/mask"}
    for topic, msgs in before.items():  # every input message, unchanged, at its bag time
        assert [(s, raw) for s, _, raw in after[topic]] == [(s, raw) for s, _, raw in msgs]
    # the PNG path's repair of the same frames
    png = tmp_path / "png"
    png.mkdir()
    for i, d in enumerate(frames):
        (png / f"{i:06d}.png").write_bytes(encode_png(d, "f"))
    code, _, err = d2sr_inprocess(
        "recover", str(png), "--repair", "all", "--models", str(weights), "--out", str(tmp_path / "p")
    )
    assert code == 0, err
    changed = 0
    for i, ((s, d, _), (rs, rep, _), (ms, mask, _)) in enumerate(
        zip(before[TOPIC], after[TOPIC + "/repaired"], after[TOPIC + "/mask"], strict=True)
    ):
        assert s == rs == ms and rep.header.stamp == d.header.stamp == mask.header.stamp
        assert rep.encoding == "16UC1" and mask.encoding == "mono8" and rep.header.frame_id == "depth"
        fixed = np.frombuffer(bytes(rep.data), np.uint16).reshape(96, 128)
        m = np.frombuffer(bytes(mask.data), np.uint8).reshape(96, 128)
        assert np.array_equal(fixed, cv2.imread(str(tmp_path / "p" / f"{i:06d}.png"), cv2.IMREAD_UNCHANGED))
        assert np.array_equal(
            m, cv2.imread(str(tmp_path / "p" / "masks" / f"{i:06d}.png"), cv2.IMREAD_UNCHANGED)
        )
        changed += int((fixed != frames[i]).sum())
    assert changed > 0


def test_float_metres_keep_their_encoding_and_nans(tmp_path, weights):
    src = tmp_path / "in"
    _write_bag(src, "mcap", "32FC1")
    code, _, err = d2sr_inprocess(
        "recover", str(src), "--repair", "all", "--models", str(weights), "--out", str(tmp_path / "o")
    )
    assert code == 0, err
    before, after = _read(src), _read(tmp_path / "o")
    for (_, d, _), (_, rep, _), (_, mask, _) in zip(
        before[TOPIC], after[TOPIC + "/repaired"], after[TOPIC + "/mask"], strict=True
    ):
        assert rep.encoding == "32FC1"
        a = np.frombuffer(bytes(d.data), np.float32)
        b = np.frombuffer(bytes(rep.data), np.float32)
        keep = np.frombuffer(bytes(mask.data), np.uint8) == 0
        assert np.array_equal(a[keep], b[keep], equal_nan=True)  # NaN (no return) kept outside the mask


def test_bag_outputs_follow_the_output_rules(tmp_path, weights):
    src = tmp_path / "in.bag"
    _write_bag(src, "ros1")
    mine = tmp_path / "notes.bag"
    _write_bag(mine, "ros1")  # a bag the user recorded, not d2sr
    code, _, err = d2sr_inprocess(
        "recover", str(src), "--models", str(weights), "--out", str(mine), "--overwrite"
    )
    assert code == 2 and "did not write" in err and len(err.strip().splitlines()) == 1
    out = tmp_path / "out.bag"
    assert d2sr_inprocess("recover", str(src), "--models", str(weights), "--out", str(out))[0] == 0
    code, _, err = d2sr_inprocess("recover", str(src), "--models", str(weights), "--out", str(out))
    assert code == 2 and "--overwrite" in err
    assert (
        d2sr_inprocess("recover", str(src), "--models", str(weights), "--out", str(out), "--overwrite")[0]
        == 0
    )
    # its own output again: refused, it already carries the repairs
    code, _, err = d2sr_inprocess(
        "recover", str(out), "--models", str(weights), "--topic", TOPIC, "--out", str(tmp_path / "again.bag")
    )
    assert code == 2 and "already has" in err and not (tmp_path / "again.bag").exists()
    # --format png: a PNG folder from a bag, as before
    code, _, err = d2sr_inprocess(
        "recover", str(src), "--models", str(weights), "--format", "png", "--out", str(tmp_path / "pngs")
    )
    assert code == 0 and len(list((tmp_path / "pngs").glob("*.png"))) == N
    code, _, err = d2sr_inprocess(
        "recover", str(tmp_path / "pngs"), "--format", "bag", "--out", str(tmp_path / "x.bag")
    )
    assert code == 2 and "ROS" in err


def test_a_ros2_output_folder_follows_the_folder_rules(tmp_path, weights):
    src = tmp_path / "in"
    _write_bag(src, "mcap")
    out = tmp_path / "out"
    w = ["--models", str(weights)]
    assert d2sr_inprocess("recover", str(src), *w, "--out", str(out))[0] == 0
    assert (out / ".d2sr-manifest.json").is_file() and (out / "metadata.yaml").is_file()
    (out / "notes.txt").write_text("mine\n")
    code, _, err = d2sr_inprocess("recover", str(src), *w, "--out", str(out))
    assert code == 2 and "--overwrite" in err
    assert d2sr_inprocess("recover", str(src), *w, "--out", str(out), "--overwrite")[0] == 0
    assert (out / "notes.txt").read_text() == "mine\n" and TOPIC + "/mask" in _read(out)
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "x.txt").write_text("x")
    code, _, err = d2sr_inprocess("recover", str(src), *w, "--out", str(theirs), "--overwrite")
    assert code == 2 and (theirs / "x.txt").read_text() == "x" and len(list(theirs.iterdir())) == 1


def test_an_output_inside_the_bag_folder_is_refused_when_the_input_names_its_file(tmp_path, weights):
    src = tmp_path / "in"
    _write_bag(src, "mcap")
    inner = next(src.glob("*.mcap"))
    before = sorted(p.name for p in src.iterdir())
    code, _, err = d2sr_inprocess(
        "recover", str(inner), "--models", str(weights), "--out", str(src / "fixed")
    )
    assert code == 2 and "input" in err and sorted(p.name for p in src.iterdir()) == before
    out = tmp_path / "fixed"
    assert d2sr_inprocess("recover", str(inner), "--models", str(weights), "--out", str(out))[0] == 0
    assert TOPIC + "/repaired" in _read(out)
