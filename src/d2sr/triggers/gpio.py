"""``gpio:CHIP:LINE``: a pin of the host itself (Jetson, Raspberry Pi) drives the camera's sync input
through libgpiod v2 (``gpiod`` on the package index). The slot clock runs in a host thread, so its timing
is the host's: Linux gives about a millisecond of jitter, well inside a 33 ms slot."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from d2sr.errors import InputError
from d2sr.triggers.host import HostActuator

__all__ = ["GpioActuator", "chip_path"]


def chip_path(chip: str) -> str:
    """``gpiochip0`` or ``0`` -> ``/dev/gpiochip0``; a path stays."""
    if chip.startswith("/"):
        return chip
    return f"/dev/{chip}" if chip.startswith("gpiochip") else f"/dev/gpiochip{chip}"


@dataclass
class GpioActuator(HostActuator):
    """``chip``: the gpiochip; ``line``: its offset or name."""

    chip: str = ""
    line: str = ""
    kind: str = "gpio"
    _request: Any = None
    _values: Any = None

    def __post_init__(self) -> None:
        try:
            import gpiod
            from gpiod.line import Direction, Value
        except ImportError:
            raise InputError(
                "the gpio trigger needs gpiod (libgpiod v2): pip install '.[triggers]'"
            ) from None
        path = chip_path(self.chip)
        key: int | str = int(self.line) if self.line.isdigit() else self.line
        settings = gpiod.LineSettings(direction=Direction.OUTPUT, output_value=Value.INACTIVE)
        try:
            self._request = gpiod.request_lines(path, consumer="d2sr", config={key: settings})
        except (OSError, ValueError) as exc:
            raise InputError(f"gpio:{self.chip}:{self.line}: cannot drive that line ({exc})") from None
        self._values = (Value.INACTIVE, Value.ACTIVE)
        self.write = lambda level: self._request.set_value(key, self._values[level])
        super().__post_init__()

    def close(self) -> None:
        super().close()
        if self._request is not None:
            self._request.release()
            self._request = None
