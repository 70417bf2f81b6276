"""d2sr.config's argument checks: None or the kind asked for passes, anything else is one ConfigError
naming the argument."""

from __future__ import annotations

from pathlib import Path

import pytest

from d2sr.config import check_callbacks, check_instances, check_paths, check_whole
from d2sr.errors import ConfigError


def test_what_is_asked_for_or_none_passes():
    check_instances(settings=(None, dict), extra=({"a": 1}, dict))
    check_callbacks(progress=None, say=print)
    check_paths(input="rec", out=Path("out"))
    check_whole("workers", 1, 1, 4)
    check_whole("workers", 4, 1, 4)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: check_instances(settings=([], dict)), "settings must be dict or None, got list"),
        (lambda: check_callbacks(progress=3), "progress must be a function or None, got int"),
        (lambda: check_paths(out=None), "out must be a path, got NoneType"),
        (lambda: check_paths(out=b"bytes"), "out must be a path, got bytes"),
        (lambda: check_whole("workers", 5, 1, 4), "workers must be a whole number in 1..4, got 5"),
        (lambda: check_whole("workers", 2.0, 1, 4), "workers must be a whole number in 1..4, got 2.0"),
        (lambda: check_whole("workers", True, 1, 4), "workers must be a whole number in 1..4, got True"),
    ],
)
def test_anything_else_is_one_config_error_naming_it(call, message):
    with pytest.raises(ConfigError, match=message):
        call()
