"""One exception family. The CLI turns any D2SRError into a one-line message and exit code 2."""

from __future__ import annotations

__all__ = ["ConfigError", "D2SRError", "InputError", "OutputError"]


class D2SRError(Exception):
    """Base of every error d2sr raises on purpose (bad input, bad settings). ``setting``: the settings field
    at fault, where one is (the command line names the flag that sets it)."""

    def __init__(self, message: str = "", setting: str | None = None) -> None:
        super().__init__(message)
        self.setting = setting


class ConfigError(D2SRError, ValueError):
    """A setting or argument is out of range or unknown."""


class InputError(D2SRError, ValueError):
    """An input (file, array, sequence) is unusable."""


class OutputError(D2SRError):
    """An output path would destroy something d2sr did not make, or cannot be written."""
