"""Configurations that would defeat the node are refused before it starts, in one line (issue 79): names
Cyclone crashes on, a remap that feeds the node its own output, a stored scene that does not load, a
parameters file that says true for a number or nests without end."""

from __future__ import annotations

import pytest

from d2sr.errors import ConfigError, InputError
from d2sr.ros2.camera import Camera
from d2sr.ros2.node import Ros2Node
from d2sr.ros2.params import read_params
from d2sr.ros2.wire import MAX_NAME, Wire, dds_topic
from helpers import d2sr_inprocess


def test_a_topic_name_longer_than_ros_2_takes_is_refused_before_cyclone():
    """A topic of 65,536 characters segfaulted inside Cyclone's DataReader (exit 139, no line)."""
    assert dds_topic("/" + "a" * (MAX_NAME - 1)) == "rt/" + "a" * (MAX_NAME - 1)
    for name in ("/" + "a" * MAX_NAME, "/" + "a" * 65_536):
        with pytest.raises(ConfigError, match=f"at most {MAX_NAME}"):
            dds_topic(name)
    # The node's own outputs (TOPIC/repaired/compressedDepth) are checked too, before any DDS entity.
    near = "/" + "a" * (MAX_NAME - 12)
    with pytest.raises(ConfigError, match=f"at most {MAX_NAME}"):
        Ros2Node(near, 4000.0, Wire(domain=150, transport="compressedDepth"))
    code, _, err = d2sr_inprocess("ros2", "--topic", "/" + "t" * 65_536)
    assert code == 2 and err.count("\n") == 1 and f"at most {MAX_NAME}" in err


@pytest.mark.parametrize(
    "rule",
    ["/cam/depth/repaired:=/cam/depth", "/cam/depth/mask:=/cam/depth", "/cam/depth/status:=/cam/camera_info"],
)
def test_a_remap_that_feeds_the_node_its_own_output_is_refused(rule):
    """TOPIC/repaired remapped onto TOPIC: one frame became 100 in 11 s."""
    with pytest.raises(ConfigError, match="repair its own output"):
        Ros2Node("/cam/depth", 4000.0, Wire(domain=150, remaps=(rule,)))
    with pytest.raises(ConfigError, match="repair its own output"):  # one camera's output, another's input
        Ros2Node(["/a/depth", "/b/depth"], 4000.0, Wire(domain=150, remaps=("/a/depth/repaired:=/b/depth",)))


def test_a_stored_scene_that_does_not_load_stops_the_node_before_it_starts(tmp_path):
    """--scene-from a missing file or /dev/zero started the node, which skipped every frame and exited 0."""
    for bad in (tmp_path / "missing.npz", "/dev/zero"):
        with pytest.raises(InputError, match="scene"):
            Ros2Node([Camera("/cam/depth", scene_from=bad)], 4000.0, Wire(domain=150))
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"PK\x03\x04" + b"\x00" * 100)
    code, _, err = d2sr_inprocess("ros2", "--topic", "/cam/depth", "--scene-from", str(junk))
    assert code == 2 and err.count("\n") == 1 and "scene" in err


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("d2sr:\n  ros__parameters:\n    active_frames: true\n", "not true or false"),
        ("d2sr:\n  ros__parameters:\n    depth_scale: true\n", "not true or false"),
        ("d2sr:\n  ros__parameters:\n    active_frames: " + "9" * 5000 + "\n", "not YAML"),
        ("d2sr:\n  ros__parameters:\n    topic: " + "[" * 30_000 + "]" * 30_000 + "\n", "not YAML"),
    ],
)
def test_a_parameters_file_that_is_not_what_it_says_is_one_line(tmp_path, text, match):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises((ConfigError, InputError), match=match):
        read_params(path, "d2sr")
