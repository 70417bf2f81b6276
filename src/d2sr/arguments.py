"""The library's entry points check what they are given before any work: a caller's mistake is one of
d2sr's errors naming the argument, not an AttributeError or TypeError from deep inside."""

from __future__ import annotations

import os
from typing import Any

from d2sr.errors import ConfigError

__all__ = ["check_callbacks", "check_instances", "check_paths"]


def check_instances(**arguments: tuple[object, type[Any]]) -> None:
    """Each ``name=(value, kind)``: the value is None or a ``kind``."""
    for name, (value, kind) in arguments.items():
        if value is not None and not isinstance(value, kind):
            raise ConfigError(f"{name} must be {kind.__name__} or None, got {type(value).__name__}")


def check_callbacks(**arguments: object) -> None:
    """Each ``name=value``: the value is None or something to call."""
    for name, value in arguments.items():
        if value is not None and not callable(value):
            raise ConfigError(f"{name} must be a function or None, got {type(value).__name__}")


def check_paths(**arguments: object) -> None:
    """Each ``name=value``: the value is a path (a str or an os.PathLike)."""
    for name, value in arguments.items():
        if not isinstance(value, str | os.PathLike):
            raise ConfigError(f"{name} must be a path, got {type(value).__name__}")
