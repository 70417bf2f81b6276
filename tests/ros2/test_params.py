"""d2sr ros2 --params-file (d2sr.ros2.params): a ROS 2 parameters file, read as data."""

from __future__ import annotations

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
    assert code == 2 and "--topic is required" in err
