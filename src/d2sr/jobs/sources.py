"""The simulated room as the loops' frame source: ``run_room`` gives each sensor's slots to its own
``SensorLoop``, whose ``RoomTrigger`` sets only that sensor's window in the world; the loops share nothing
but the world. (A recording: ``session.run_recording``; a live camera: ``live.run_live``.)"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from d2sr.frames.base import Frame
from d2sr.runtime.loop import Capture, Result, SensorLoop
from d2sr.sim.lockstep import SimRoom, SlotEnd
from d2sr.sim.record import EPOCH_NS

__all__ = ["RoomTrigger", "run_room"]


@dataclass
class RoomTrigger:
    """A sensor's trigger line into the simulated world."""

    room: SimRoom
    sensor: int

    def set_offset(self, period: int, offset: int) -> None:
        self.room.set_offset(self.sensor, period, offset)


def run_room(
    room: SimRoom, loops: list[SensorLoop], seconds: float, progress: Callable[[float], None] | None = None
) -> Iterator[tuple[SlotEnd, Result | None]]:
    """Run the world; each sensor's slots go to its own loop. Yields every slot with its frame's result."""
    if len(loops) != room.n:
        raise ValueError(f"{len(loops)} loops for {room.n} sensors")
    scale = room.model.depth_scale
    total = room.cfg.total_frames
    for ev in room.slots(seconds):
        loop, res = loops[ev.sensor], None
        if ev.frame is not None:
            f = ev.frame
            frame = Frame(f"{f.slot:06d}", f.depth, EPOCH_NS + round(f.time_s * 1e9))
            res = loop.process(Capture(frame, scale, f.slot % total, f.clean, f.mask, f.interfered))
        if ev.period_end:
            loop.end_period()
            if progress is not None and ev.sensor == 0:
                progress(min(1.0, ev.time_s / seconds))
        yield ev, res
