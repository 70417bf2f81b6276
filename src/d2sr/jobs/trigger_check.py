"""``d2sr trigger check``: a trigger's board or pin, exercised without a camera: the firmware's handshake,
the command-to-pulse round trip (serial), and the slot clock run for a while with a window."""

from __future__ import annotations

import time
from dataclasses import dataclass

from d2sr.desync.base import DEFAULT_ACTIVE
from d2sr.errors import ConfigError
from d2sr.jobs.stats import median_p99_ms
from d2sr.triggers import open_trigger, parse_trigger

__all__ = ["TriggerCheck", "check_trigger"]


@dataclass(frozen=True)
class TriggerCheck:
    kind: str
    round_trip_ms: tuple[float, float] | None  # median, p99 (serial only)
    periods: int
    pulses: int  # active slots the clock reported
    expected: int  # active slots it should have reported
    late_ms: tuple[float, float]  # reports after the host's estimate of their slot: median, p99

    def lines(self) -> list[str]:
        out = []
        if self.round_trip_ms is not None:
            out.append(f"round trip, command to pulse: {self.round_trip_ms[0]:.2f} ms median, "
                       f"{self.round_trip_ms[1]:.2f} ms p99")  # fmt: skip
        out.append(f"{self.periods} periods: {self.pulses} of {self.expected} active slots reported, "
                   f"{self.late_ms[0]:.2f} ms median after their slot began "
                   f"({self.late_ms[1]:.2f} ms p99)")  # fmt: skip
        return out


def check_trigger(
    spec: str, active_frames: int = DEFAULT_ACTIVE, seconds: float = 3.0, pings: int = 100
) -> TriggerCheck:
    """Open ``spec`` (``serial:`` or ``gpio:``), time ``pings`` round trips (serial), then run the clock with
    a window of ``active_frames`` slots for ``seconds`` and count what it reported."""
    kind = parse_trigger(spec)[0]
    if kind not in ("serial", "gpio"):
        raise ConfigError(f"trigger check drives serial: and gpio: lines; {kind} needs its camera (d2sr run)")
    if not seconds > 0 or pings < 0:
        raise ConfigError("need seconds > 0 and pings >= 0")
    with open_trigger(spec, active_frames) as act:
        trips = act.round_trips(pings) if kind == "serial" and pings else None  # type: ignore[attr-defined]
        act.set_offset(0, 0)
        act.start()
        time.sleep(seconds)
        pulses = list(act.pulses)
        clock = act.clock
    periods = int(seconds)  # whole 1 s periods run
    start = clock.start_s or 0.0
    late = [p.host_s - start - (p.period * act.total + p.slot) * clock.slot_s for p in pulses]
    seen = sum(p.period < periods for p in pulses)
    per_period = min(act.total, active_frames + act.lead)
    return TriggerCheck(
        kind,
        median_p99_ms(trips) if trips else None,
        periods,
        seen,
        periods * per_period,
        median_p99_ms(late),
    )
