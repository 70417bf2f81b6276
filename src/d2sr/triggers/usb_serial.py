"""``serial:PORT``: a microcontroller on the host's USB (one per sensor, no wire between sensors) runs the
slot clock and drives the camera's sync input; the host sends it the window. The firmware is
``d2sr.triggers.firmware`` (MicroPython); the protocol is its module docstring."""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from d2sr.errors import InputError
from d2sr.triggers.base import SLOT_S, Actuator

__all__ = ["SerialActuator"]

BAUD = 115200  # USB CDC ignores it; a UART bridge needs it to match
ANSWER_S = 2.0  # the firmware answers HELLO within this


@dataclass
class SerialActuator(Actuator):
    """``port``: a device path or pyserial URL. ``pulse_s``: 0 holds the line high through the window
    (L515), else one pulse of that length per active slot (D400 genlock, Azure Kinect, Orbbec)."""

    port: str = ""
    pulse_s: float = 0.0
    kind: str = "serial"
    _serial: Any = None
    _reader: threading.Thread | None = None
    _replies: list[tuple[str, float]] = field(default_factory=list)
    _cv: threading.Condition = field(default_factory=threading.Condition)
    _closing: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        try:
            import serial
        except ImportError:
            raise InputError("the serial trigger needs pyserial: pip install '.[triggers]'") from None
        try:
            self._serial = serial.serial_for_url(self.port, baudrate=BAUD, timeout=0.05)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise InputError(f"serial:{self.port}: cannot open ({_first_line(exc)})") from None
        self._reader = threading.Thread(target=self._read, name="d2sr-serial-read", daemon=True)
        self._reader.start()
        try:
            hello = self.ask("HELLO", "D2SR")
            words = hello.split()
            if len(words) != 5:
                raise InputError(f"serial:{self.port}: not the d2sr trigger firmware (it said {hello!r})")
            slot_us = round(SLOT_S * 1e6)
            self.ask(f"CFG {self.total} {slot_us} {round(self.pulse_s * 1e6)}", "OK CFG")
        except BaseException:
            self.close()
            raise

    def start(self) -> None:
        self.ask("START 0", "OK START")

    def send(self, line: str) -> None:
        if self.closed and line != "STOP":
            return  # a settle timer that fired after close
        self._serial.write((line + "\n").encode())
        self._serial.flush()

    def ask(self, line: str, answer: str, timeout_s: float = ANSWER_S) -> str:
        """Send ``line`` and wait for the reply that starts with ``answer``."""
        with self._cv:
            self._replies.clear()
        self.send(line)
        end = time.monotonic() + timeout_s
        with self._cv:
            while True:
                for text, _ in self._replies:
                    if text.startswith(answer):
                        return text
                    if text.startswith("ERR"):
                        raise InputError(f"serial:{self.port}: the firmware refused {line!r}: {text[4:]}")
                left = end - time.monotonic()
                if left <= 0:
                    raise InputError(f"serial:{self.port}: no d2sr trigger firmware answered {line!r}")
                self._cv.wait(left)

    def round_trips(self, n: int = 100) -> list[float]:
        """Seconds from sending ``PING`` to reading the reply the firmware writes once its line is up: the
        command-to-pulse round trip (call it before ``start``)."""
        times = []
        for k in range(n):
            t = time.perf_counter()
            self.ask(f"PING {k}", f"PONG {k} ")
            times.append(time.perf_counter() - t)
        return times

    def close(self) -> None:
        if self._serial is None or self._closing:
            return
        self._closing = True
        super().close()
        with contextlib.suppress(Exception):  # the port may be gone; closing must still release it
            self.send("STOP")
        if self._reader is not None:
            self._reader.join(timeout=1)
        self._serial.close()

    def _read(self) -> None:
        buf = b""
        while not self._closing:
            try:
                chunk = self._serial.read(max(1, self._serial.in_waiting))
            except Exception:  # the port went away: the loop sees no more pulses
                return
            if not chunk:
                continue
            now = time.monotonic()
            buf += chunk
            *lines, buf = buf.split(b"\n")
            for raw in lines:
                text = raw.decode("ascii", "replace").strip()
                self.on_line(text, now)
                if text and not text.startswith(("P ", "E ")):
                    with self._cv:
                        self._replies.append((text, now))
                        self._cv.notify_all()


def _first_line(exc: BaseException) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
