"""d2sr simulate: the recording layout, its metadata, readability through d2sr.frames, bad options."""

from __future__ import annotations

import json

import cv2
import numpy as np

from d2sr.frames import open_frames
from helpers import d2sr as _cli


def test_simulate_writes_consistent_recordings(tmp_path):
    out = tmp_path / "sim"
    r = _cli(
        "simulate",
        "--out",
        str(out),
        "--sensors",
        "2",
        "--seconds",
        "2",
        "--active-frames",
        "15",
        "--resolution",
        "80x60",
        "--seed",
        "3",
        "--workers",
        "1",
    )
    assert r.returncode == 0, r.stderr
    scene = json.loads((out / "scene.json").read_text())
    assert scene["sensors"] == 2 and scene["frames"] > 0
    total = bad = 0
    for i in range(2):
        depth, clean = (open_frames(out / f"sensor{i}" / s) for s in ("depth", "clean"))
        assert depth.depth_scale == 4000.0 and depth.intrinsics is not None and depth.shape == (60, 80)
        meta = json.loads((out / f"sensor{i}" / "depth" / "meta.json").read_text())["frames"]
        stamps = [m["timestamp_ns"] for m in meta]
        assert stamps == sorted(stamps)
        for m, d, c in zip(meta, depth, clean, strict=True):
            mask = cv2.imread(str(out / f"sensor{i}" / "masks" / f"{d.name}.png"), cv2.IMREAD_UNCHANGED)
            assert mask.dtype == np.uint8
            assert np.array_equal(mask > 0, d.depth != c.depth)  # the mask is exactly what changed
            assert m["interfered"] == bool((mask > 0).any())
            total += 1
            bad += m["interfered"]
    assert total == scene["frames"] and bad == scene["interfered_frames"]
    assert 0 < bad < total  # two sensors at half duty with static offsets: some frames hit, some not


def test_simulate_ros2_bag(tmp_path):
    out = tmp_path / "sim"
    r = _cli(
        "simulate",
        "--out",
        str(out),
        "--sensors",
        "2",
        "--seconds",
        "1",
        "--resolution",
        "64x48",
        "--format",
        "ros2",
        "--workers",
        "1",
    )
    assert r.returncode == 0, r.stderr
    bag = open_frames(out / "sensor0" / "depth_ros2")
    assert bag.depth_scale == 1000.0 and len(bag) > 0 and not (out / "sensor0" / "depth").exists()


def test_simulate_bad_options(tmp_path):
    for args, msg in (
        (["--sensors", "0"], "sensors"),
        (["--controller", "nope"], "unknown controller"),
        (["--resolution", "big"], "resolution"),
        (["--format", "avi"], "format"),
        (
            ["--seconds", "1e12"],
            "seconds: Input should be less than or equal to 3600",
        ),  # a MemoryError before
        (["--people", "1000000"], "people must be a whole number in 0..20"),  # rendered for hours before
        (["--workers", "100000"], "workers: Input should be less than or equal to 256"),  # took the memory
    ):
        r = _cli("simulate", "--out", str(tmp_path / "o"), *args)
        assert r.returncode == 2 and msg in r.stderr and "Traceback" not in r.stderr, (args, r.stderr)
    assert not (tmp_path / "o").exists()


def test_deprecated_option_names_still_work_and_say_so(tmp_path):
    r = _cli(
        "simulate", "--out", str(tmp_path / "o"), "--sensors", "2", "--seconds", "1", "--fps", "6",
        "--moving-robot", "--resolution", "80x60", "--workers", "1",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "--fps is deprecated" in r.stderr and "use --active-frames" in r.stderr
    assert "--moving-robot is deprecated" in r.stderr
    scene = json.loads((tmp_path / "o" / "scene.json").read_text())
    assert scene["active_frames"] == 6 and any(scene["moving"])
