"""Actuators whose slot clock runs on the host: the firmware's ``Core`` in a thread, its line driving a
callback (a GPIO pin, a D400 emitter, an Orbbec software trigger) instead of a pin."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from d2sr.triggers.base import SLOT_S, Actuator
from d2sr.triggers.firmware.d2sr_trigger import Core

__all__ = ["HostActuator"]


def _now_us() -> int:
    return time.monotonic_ns() // 1000


@dataclass
class HostActuator(Actuator):
    """``write(level)`` is called with 1 when the line goes up and 0 when it goes down: per active slot
    (``pulse_s`` > 0) or held through the window (``pulse_s`` = 0). With ``in_background`` the calls run on
    a worker of their own, so a slow device call (an emitter switch takes hundreds of ms) never delays the
    clock."""

    write: Callable[[int], None] = lambda level: None
    pulse_s: float = 0.0
    in_background: bool = False
    _core: Core | None = None
    _thread: threading.Thread | None = None
    _stop: threading.Event = field(default_factory=threading.Event)
    _commands: queue.SimpleQueue[str] = field(default_factory=queue.SimpleQueue)
    _work: queue.SimpleQueue[int | None] = field(default_factory=queue.SimpleQueue)
    _worker: threading.Thread | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self._core = Core(
            self._line,
            _now_us,
            lambda text: self.on_line(text, time.monotonic()),
            slots=self.total,
            slot_us=round(SLOT_S * 1e6),
            pulse_us=round(self.pulse_s * 1e6),
        )
        if self.in_background:
            self._worker = threading.Thread(target=self._drain, name=f"d2sr-{self.kind}-line", daemon=True)
            self._worker.start()
        self._thread = threading.Thread(target=self._run, name=f"d2sr-{self.kind}-clock", daemon=True)
        self._thread.start()

    def send(self, line: str) -> None:
        self._commands.put(line)

    def start(self) -> None:
        """Start the clock at period 0, and return once it runs."""
        super().start()
        end = time.monotonic() + 2
        while self.clock.start_s is None and time.monotonic() < end:
            time.sleep(0.001)

    def close(self) -> None:
        super().close()
        if self._thread is not None and self._thread.is_alive():
            self.send("STOP")
            self._stop.set()
            self._thread.join(timeout=2)
        if self._worker is not None:
            self._work.put(None)
            self._worker.join(timeout=5)
            self._worker = None

    def _line(self, level: int) -> None:
        if self._worker is not None:
            self._work.put(level)
        else:
            self.write(level)

    def _drain(self) -> None:
        while (level := self._work.get()) is not None:
            self.write(level)

    def _run(self) -> None:
        core = self._core
        assert core is not None
        while not self._stop.is_set():
            while not self._commands.empty():
                core.line(self._commands.get())
            wait = core.poll()
            self._stop.wait(max(wait, 100) / 1e6)
