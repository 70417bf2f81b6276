"""``d2sr ros2`` as one call: a parameters file fills what the command line did not give, never what it did;
a node with no topic or a bad time is refused before DDS starts."""

from __future__ import annotations

import pytest

from d2sr.errors import ConfigError
from d2sr.ros2.serve import _merged, serve


def test_the_file_fills_what_was_not_given_and_never_what_was(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text("d2sr:\n  ros__parameters:\n    topic: /file/depth\n    passes: 2\n")
    options = {"node_name": "d2sr", "topic": ["/flag/depth"], "passes": None}
    want = {"node_name": "d2sr", "topic": ["/flag/depth"], "passes": 2}
    assert _merged(options, f, given={"topic"}) == want
    assert _merged(options, f, given=())["topic"] == "/file/depth"
    assert _merged(options, None, given=()) == options


@pytest.mark.parametrize(
    ("topic", "seconds", "named"), [(None, 1.0, "topic"), (["/a/depth"], 0.0, "seconds")]
)
def test_no_topic_or_no_time_is_refused_naming_its_setting(topic, seconds, named):
    with pytest.raises(ConfigError) as e:
        serve({"node_name": "d2sr", "topic": topic, "seconds": seconds})
    assert e.value.setting == named


def test_the_node_keeps_freed_frame_buffers_for_the_next_frames(monkeypatch):
    """As recover's and run's loops do (``d2sr.jobs.memory``), before the node starts."""
    import d2sr.ros2.serve as served

    calls = []

    class Started(Exception):
        pass

    def node(*args, **kwargs):
        calls.append("node")
        raise Started

    monkeypatch.setattr(served, "reuse_freed_memory", lambda: calls.append("reuse") or True)
    monkeypatch.setattr(served, "Ros2Node", node)
    options = {"node_name": "d2sr", "topic": ["/a/depth"], "seconds": 1.0, "colour_topic": None}
    options |= {"trigger": None, "scene_from": None, "repair": "flagged", "model": "auto", "models": "m"}
    options |= {"threshold": None, "mask_logit": None, "passes": None, "scene": True, "qos": "reliable"}
    options |= {"transport": "raw", "namespace": "/", "remap": None, "controller": "robust"}
    with pytest.raises(Started):
        served.serve(options | {"depth_scale": None, "active_frames": 6})
    assert calls == ["reuse", "node"]
