"""What every actuator shares: the window it is told (``set_offset``), the slot clock its device runs, and
where a frame that reached the host lies in that clock (``locate``).

The clock is the firmware's ``Core`` (``firmware/d2sr_trigger.py``): on a microcontroller for the ``serial``
trigger, in a host thread for the others. Either way it reports each active slot as a line
``P <period> <slot> <t_us>``; the host keeps the earliest-arriving estimate of where slot 0 began, so a
frame's arrival time, less the sensor's latency, gives its slot.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from d2sr.desync import TOTAL_FRAMES
from d2sr.errors import ConfigError

__all__ = ["SLOT_S", "Actuator", "Pulse", "SlotClock", "device_window"]

SLOT_S = 1 / TOTAL_FRAMES  # one slot of the 1 s period at 30 fps


def device_window(offset: int, active: int, lead: int, total: int = TOTAL_FRAMES) -> tuple[int, int]:
    """The window the device runs for the controller's (offset, active): its line (laser, emitter) goes on
    ``lead`` slots early, because the sensor needs that long before its first frame (L515: 60 ms; a D400
    emitter: hundreds of ms)."""
    n = min(total, active + lead)
    return (offset - (n - active)) % total, n


@dataclass
class Pulse:
    """An active slot as the device reported it, with the host time the report arrived."""

    period: int
    slot: int
    host_s: float


@dataclass
class SlotClock:
    """Where the device's slot grid lies in host time (``time.monotonic``)."""

    total: int = TOTAL_FRAMES
    slot_s: float = SLOT_S
    start_s: float | None = None  # host time slot 0 of period 0 began (earliest estimate)

    def observe(self, period: int, slot: int, host_s: float) -> None:
        """A report of slot ``slot`` of ``period`` that reached the host at ``host_s``: the transport only
        delays, so the earliest estimate is the best."""
        guess = host_s - (period * self.total + slot) * self.slot_s
        self.start_s = guess if self.start_s is None else min(self.start_s, guess)

    def at(self, host_s: float, nearest: bool = False) -> tuple[int, int]:
        """(period, slot) at host time ``host_s``: the slot running then, or (``nearest``) the slot whose
        start lies nearest to it."""
        if self.start_s is None:
            raise RuntimeError("the slot clock has not started")
        x = (host_s - self.start_s) / self.slot_s
        k = round(x) if nearest else math.floor(x + 1e-9)
        return k // self.total, k % self.total


@dataclass
class Actuator:
    """Base of the triggers that reach a real sensor. ``active_frames``: the controller's window length;
    ``lead``: slots the device's line goes on before the window; ``latency_s``: from a slot's start to its
    frame reaching the host."""

    active_frames: int
    lead: int = 0
    latency_s: float = 0.0
    total: int = TOTAL_FRAMES
    kind: str = "actuator"
    clock: SlotClock = field(default_factory=SlotClock)
    pulses: deque[Pulse] = field(default_factory=lambda: deque(maxlen=4 * TOTAL_FRAMES))
    # Called with a period once its last frame can have reached the host (its end plus ``latency_s``).
    on_settled: Callable[[int], None] | None = None
    closed: bool = False
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def __post_init__(self) -> None:
        if not 1 <= self.active_frames <= self.total:
            raise ConfigError(f"active frames must be in 1..{self.total}, got {self.active_frames}")
        if self.lead < 0 or self.latency_s < 0:
            raise ConfigError("lead and latency must not be negative")

    # -- what the loop calls --
    def set_offset(self, period: int, offset: int) -> None:
        """The controller's window from ``period`` on starts at slot ``offset``."""
        start, n = device_window(offset, self.active_frames, self.lead, self.total)
        self.send(f"WIN {period} {start} {n}")

    def start(self) -> None:
        """Start the device's slot clock at period 0."""
        self.send("START 0")

    def locate(self, arrival_s: float) -> tuple[int, int]:
        """The (period, slot) of a frame that reached the host at ``arrival_s`` (``time.monotonic``): the
        slot whose start lies nearest to its arrival less the latency, so jitter either way of half a slot
        (17 ms) still finds it."""
        with self._lock:
            return self.clock.at(arrival_s - self.latency_s, nearest=True)

    def close(self) -> None:
        """Stop the device's clock and release it."""
        self.closed = True

    def _settle(self, period: int) -> None:
        if not self.closed and self.on_settled is not None:
            self.on_settled(period)

    def __enter__(self) -> Actuator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- device side --
    def send(self, line: str) -> None:
        raise NotImplementedError

    def on_line(self, line: str, host_s: float) -> None:
        """A line from the device's clock."""
        words = line.split()
        if len(words) == 3 and words[:2] == ["OK", "START"]:  # slot 0 began just before this reply
            with self._lock:
                self.clock.observe(int(words[2]), 0, host_s)
        elif len(words) == 4 and words[0] == "P":
            period, slot = int(words[1]), int(words[2])
            with self._lock:
                self.clock.observe(period, slot, host_s)
                self.pulses.append(Pulse(period, slot, host_s))
        elif len(words) == 2 and words[0] == "E" and self.on_settled is not None:
            timer = threading.Timer(self.latency_s, self._settle, (int(words[1]),))
            timer.daemon = True
            timer.start()
