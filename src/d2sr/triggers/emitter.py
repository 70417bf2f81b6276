"""``realsense-emitter``: a D400's projector switched from software (``emitter_enabled``), on through the
controller's window and off outside it. A switch takes on the order of hundreds of ms (librealsense #6607)
and toggling fast gives "Device or resource busy" (realsense-ros #1363), so the projector goes on ``lead``
slots early and the switch calls run on a worker of their own, never in the clock's way."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from d2sr.errors import InputError
from d2sr.triggers.base import SLOT_S
from d2sr.triggers.host import HostActuator

__all__ = ["SWITCH_S", "EmitterActuator"]

SWITCH_S = 0.3  # documented order of a D400 emitter switch (#6607); measure yours with `d2sr trigger check`


@dataclass
class EmitterActuator(HostActuator):
    """``sensor``: the pyrealsense2 depth sensor (``attach`` it once the camera is open)."""

    switch_s: float = SWITCH_S
    in_background: bool = True
    kind: str = "realsense-emitter"
    sensor: Any = None
    switches: int = 0  # calls that reached the sensor
    _option: Any = None

    def __post_init__(self) -> None:
        self.lead = max(self.lead, math.ceil(self.switch_s / SLOT_S - 1e-9))
        self.write = self._switch
        super().__post_init__()

    @property
    def unbound(self) -> str | None:
        """What this trigger still needs before it acts on anything (None: nothing)."""
        return "a RealSense depth sensor (attach(sensor))" if self.sensor is None else None

    def attach(self, sensor: Any) -> None:
        """Drive this sensor's emitter from now on (the projector starts off)."""
        from d2sr.frames.realsense import import_rs

        rs = import_rs()
        if not sensor.supports(rs.option.emitter_enabled):
            raise InputError("realsense-emitter: this sensor has no emitter_enabled option (a D400 has)")
        self._option = rs.option.emitter_enabled
        self.sensor = sensor
        self._set(0)

    def _switch(self, level: int) -> None:
        if self.sensor is not None:
            self._set(level)

    def _set(self, level: int) -> None:
        """Switch, trying again for up to one switch time while the device says it is busy."""
        end = time.monotonic() + self.switch_s
        while True:
            try:
                self.sensor.set_option(self._option, float(level))
                self.switches += 1
                return
            except RuntimeError:  # "Device or resource busy"
                if time.monotonic() > end:
                    return
                time.sleep(SLOT_S)
