"""d2sr ros2 --params-file (d2sr.ros2.params): a ROS 2 parameters file, read as data."""

from __future__ import annotations

import random
import signal

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from d2sr.errors import ConfigError, D2SRError, InputError
from d2sr.ros2.params import read_params
from helpers import d2sr_inprocess

FILE = """
/**:
  ros__parameters:
    depth_scale: 4000
    active_frames: 10
d2sr:
  ros__parameters:
    topic: /cam/depth/image_raw
    active_frames: 6
other:
  ros__parameters:
    topic: /not/mine
"""


def test_the_node_s_section_over_every_node_s_and_nothing_of_another_node(tmp_path):
    f = tmp_path / "params.yaml"
    f.write_text(FILE)
    assert read_params(f, "d2sr") == {
        "depth_scale": 4000.0,
        "active_frames": 6,
        "topic": "/cam/depth/image_raw",
    }
    assert read_params(f, "elsewhere") == {"depth_scale": 4000.0, "active_frames": 10}


@pytest.mark.parametrize(
    ("text", "kind", "says"),
    [
        ("d2sr:\n  ros__parameters:\n    topik: /x\n", ConfigError, "topik"),
        ("d2sr:\n  ros__parameters:\n    active_frames: many\n", ConfigError, "active_frames"),
        ("d2sr: [1, 2\n", InputError, "not YAML"),
        ("- just\n- a list\n", InputError, "not a ROS 2 parameters file"),
        ("d2sr:\n  topic: /x\n", InputError, "ros__parameters"),
        (
            "d2sr:\n  ros__parameters:\n    topic: !!python/object/apply:os.system ['true']\n",
            InputError,
            "not YAML",
        ),
    ],
)
def test_a_file_that_is_not_one_is_one_line(tmp_path, text, kind, says):
    f = tmp_path / "p.yaml"
    f.write_text(text)
    with pytest.raises(kind, match=says) as got:
        read_params(f, "d2sr")
    assert "\n" not in str(got.value)


@settings(max_examples=80, deadline=None)
@given(st.binary(max_size=300))
def test_any_bytes_are_read_or_refused_in_one_line(tmp_path_factory, data):
    f = tmp_path_factory.mktemp("p") / "p.yaml"
    f.write_bytes(data)
    try:
        read_params(f, "d2sr")
    except D2SRError as exc:
        assert "\n" not in str(exc)


def test_the_command_takes_the_file_and_a_flag_wins(tmp_path):
    f = tmp_path / "params.yaml"
    f.write_text(FILE.replace("/cam/depth/image_raw", "/from/file"))
    code, out, err = d2sr_inprocess("ros2", "--params-file", str(f), "--seconds", "0.3")
    assert code == 0, err
    assert "d2sr ros2: /from/file -> /from/file/repaired" in out
    code, out, err = d2sr_inprocess(
        "ros2", "--params-file", str(f), "--topic", "/from/flag", "--seconds", "0.3"
    )
    assert code == 0, err
    assert "d2sr ros2: /from/flag ->" in out
    code, _, err = d2sr_inprocess("ros2", "--seconds", "0.3")
    assert code == 2 and "topic is required" in err and "--topic" in err


def test_each_stream_takes_sensor_data_in_and_the_system_default_out_unless_told():
    from d2sr.ros2 import Wire

    w = Wire()
    assert w.profile("depth") == (False, 5) and w.profile("info") == (False, 5)  # REP 2003: sensor data in
    assert w.profile("repaired") == (True, 10) and w.profile("diagnostics") == (
        True,
        10,
    )  # system default out
    assert Wire(qos="best-effort").profile("mask") == (False, 5)
    told = Wire(streams=(("mask", "SENSOR_DATA"), ("depth", "SYSTEM_DEFAULT")))
    assert told.profile("mask") == (False, 5) and told.profile("depth") == (True, 10)


def test_a_stream_s_qos_in_the_file_reaches_the_wire(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text("d2sr:\n  ros__parameters:\n    mask_qos: SENSOR_DATA\n    depth_qos: SYSTEM_DEFAULT\n")
    assert read_params(f, "d2sr") == {"mask_qos": "SENSOR_DATA", "depth_qos": "SYSTEM_DEFAULT"}
    f.write_text("d2sr:\n  ros__parameters:\n    mask_qos: FAST\n")
    with pytest.raises(ConfigError, match="mask_qos"):
        read_params(f, "d2sr")


@pytest.mark.slow
def test_a_best_effort_mask_does_not_match_a_reliable_reader_while_the_rest_do(tmp_path):
    import os
    import subprocess
    import sys
    import time

    from tools import ros2_peer

    f = tmp_path / "p.yaml"
    f.write_text(
        "d2sr:\n  ros__parameters:\n    topic: /camera/depth/image_rect_raw\n    mask_qos: SENSOR_DATA\n"
    )
    domain = random.randint(100, 200)
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    node = subprocess.Popen([sys.executable, "-m", "d2sr", "ros2", "--params-file", str(f)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    peer = ros2_peer.Peer(domain)  # reliable readers: they match reliable writers only
    try:
        end = time.monotonic() + 30
        for stream in ("repaired", "status"):  # discovery may take a while on a busy machine
            while not peer.readers[stream].get_matched_publications():
                assert time.monotonic() < end, f"the node's /{stream} never matched"
                time.sleep(0.05)
        time.sleep(1.0)  # announced with the others, the mask given time still does not match
        assert not peer.readers["mask"].get_matched_publications()
    finally:
        node.send_signal(signal.SIGINT)
        node.communicate(timeout=30)


def test_the_documented_parameters_file_is_read_as_it_says(tmp_path):
    """docs/examples/ros2_params.yaml: two cameras, a namespace, QoS per stream and a remapping rule."""
    from pathlib import Path

    from d2sr.ros2 import Wire

    p = read_params(Path(__file__).parents[2] / "docs" / "examples" / "ros2_params.yaml", "d2sr")
    assert p["topic"] == ["front/depth/image_rect_raw", "rear/depth/image_rect_raw"]
    w = Wire(namespace=p["namespace"], remaps=tuple(p["remap"]))
    assert w.resolve(p["topic"][0]) == "/robot1/front/depth/image_rect_raw"
    assert w.resolve(p["topic"][0] + "/repaired") == "/robot1/front/depth/repaired"
    f = tmp_path / "p.yaml"
    f.write_text("d2sr:\n  ros__parameters:\n    color_qos: SYSTEM_DEFAULT\n    topic: [/a, 3]\n")
    with pytest.raises(ConfigError, match="topic"):
        read_params(f, "d2sr")
    f.write_text("d2sr:\n  ros__parameters:\n    color_qos: SYSTEM_DEFAULT\n")
    assert read_params(f, "d2sr") == {"colour_qos": "SYSTEM_DEFAULT"}  # realsense-ros's spelling
