"""A sensor's loop closed through an actuator (``d2sr.triggers``): each frame's slot comes from its arrival
time on the actuator's clock, and each period ends once its last frame can have arrived, from the
actuator's own thread, so the controller decides even when no frame comes (a window that interference
empties)."""

from __future__ import annotations

import threading
import time

from d2sr.runtime.loop import Capture, Decision, Result, SensorLoop
from d2sr.triggers import Actuator

__all__ = ["ClosedLoop"]


class ClosedLoop:
    """``loop`` driven by ``actuator``: the loop's window goes to the actuator, which starts its clock."""

    def __init__(self, loop: SensorLoop, actuator: Actuator) -> None:
        self.loop = loop
        self.actuator = actuator
        self.late = 0  # frames that arrived after their period had closed
        self._lock = threading.Lock()
        loop.trigger = actuator
        actuator.set_offset(loop.period, loop.controller.offset)
        actuator.on_settled = self._settled
        actuator.start()

    def process(self, cap: Capture, arrival_s: float | None = None) -> Result:
        """One frame that reached the host at ``arrival_s`` (``time.monotonic``; None: now)."""
        return self.loop.finish(self.decide(cap, arrival_s))

    def decide(self, cap: Capture, arrival_s: float | None = None) -> Decision:
        """``SensorLoop.decide`` for a frame that reached the host at ``arrival_s``, in its slot."""
        period, slot = self.actuator.locate(time.monotonic() if arrival_s is None else arrival_s)
        with self._lock:
            self._end_before(period)
            cap.slot = slot
            cap.counted = period == self.loop.period
            self.late += not cap.counted
            return self.loop.decide(cap)

    def _settled(self, period: int) -> None:
        with self._lock:
            self._end_before(period + 1)

    def _end_before(self, period: int) -> None:
        while self.loop.period < period:
            self.loop.end_period()
