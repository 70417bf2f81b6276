"""The demo's library call refuses a length it cannot run before any work (the CLI's error says the flag)."""

from __future__ import annotations

import pytest

from d2sr.errors import ConfigError
from d2sr.eval.demo import run_demo


@pytest.mark.parametrize("seconds", [float("inf"), 1e9, float("nan"), 0.0, -5.0])
def test_a_demo_length_it_cannot_run_is_one_config_error(tmp_path, seconds):
    """inf overflowed into an unforeseen error; a billion seconds ran for ever."""
    with pytest.raises(ConfigError, match=r"seconds must be in \(0, 3600\]"):
        run_demo(None, tmp_path / "demo", seconds=seconds)  # type: ignore[arg-type]
    assert not (tmp_path / "demo").exists()
