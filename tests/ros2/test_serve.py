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
