"""Settings are pydantic models; this module turns their validation errors into one-line ConfigErrors, and
checks the entry points' other arguments (paths, objects of a kind, callbacks) the same way."""

from __future__ import annotations

import json
import numbers
import os
import tomllib
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from d2sr.errors import ConfigError

__all__ = [
    "Settings",
    "check_callbacks",
    "check_instances",
    "check_paths",
    "check_whole",
    "load_toml",
    "one_line",
    "read_toml",
]

M = TypeVar("M", bound="Settings")


class Settings(BaseModel):
    """Base of d2sr's settings: frozen, no unknown keys, validated on construction."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    def __init__(self, **values: Any) -> None:
        # d2sr's own error, one line, however the settings are built (``make`` says the same).
        try:
            super().__init__(**values)
        except ValidationError as exc:
            errors = exc.errors()
            field = str(errors[0]["loc"][0]) if errors and errors[0]["loc"] else None
            raise ConfigError(one_line(exc, type(self).__name__), field) from None

    @classmethod
    def make(cls: type[M], **values: Any) -> M:
        """Build and validate, raising ConfigError (one line) instead of pydantic's ValidationError."""
        return cls(**values)


def one_line(exc: ValidationError, what: str) -> str:
    """'TimingSettings: recall: Input should be less than or equal to 1 (got 1.5); ...'."""
    parts = []
    for err in exc.errors():
        field = ".".join(str(p) for p in err["loc"]) or "value"
        got = err.get("input")
        shown = "" if isinstance(got, dict) or repr(got) in err["msg"] else f" (got {got!r})"
        msg = err["msg"].removeprefix("Value error, ")  # a validator's own words need no label
        parts.append(f"{field}: {msg}{shown}")
    return f"{what}: " + "; ".join(parts)


JSON_BYTES = 1 << 20  # a small JSON file d2sr reads back (a description, a manifest, settings): at most this


def read_json(path: Path, most: int = JSON_BYTES) -> Any:
    """A small JSON file d2sr reads back, as data: a ValueError (one line) for a file over ``most`` bytes, not
    JSON, nested too deep, or holding a number Python will not read (5,000 digits); OSError as the system
    says."""
    with open(path, "rb") as fh:
        raw = fh.read(most + 1)
    if len(raw) > most:
        raise ValueError(f"larger than {most:,} bytes")
    try:
        return json.loads(raw.decode("utf-8"))
    except RecursionError:
        raise ValueError("nested too deep") from None
    except (UnicodeDecodeError, ValueError) as exc:  # JSONDecodeError, an integer of thousands of digits
        raise ValueError(str(exc).splitlines()[0][:120] if str(exc) else "not JSON") from None


def read_toml(path: Path) -> dict[str, Any]:
    """A TOML file as a dict; one-line ConfigErrors for a missing or invalid file."""
    try:
        return tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None


def load_toml(cls: type[M], path: Path) -> M:
    """Read a TOML file into a settings model."""
    return cls.make(**read_toml(path))


# The library's entry points check what they are given before any work: a caller's mistake is one of
# d2sr's errors naming the argument, not an AttributeError or TypeError from deep inside.


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


def check_whole(name: str, value: object, lo: int, hi: int) -> None:
    """``value`` is a whole number in ``lo..hi`` (not a bool): a count that sizes work or memory."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not lo <= int(value) <= hi:
        raise ConfigError(f"{name} must be a whole number in {lo}..{hi}, got {str(value)[:40]}", name)
