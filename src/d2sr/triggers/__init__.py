"""Stage 2 on real sensors: actuators that move a sensor's active window as its controller decides, with no
wire between sensors. Each is a ``Trigger`` for the loop (``set_offset``) with a slot clock that tells the
loop where each frame lies (``locate``). Torch-free.

- ``serial:PORT[@INPUT]``: a microcontroller on the host's USB pulses the camera's sync input
  (firmware: ``d2sr.triggers.firmware``);
- ``gpio:CHIP:LINE[@INPUT]``: a host pin does the same (libgpiod v2);
- ``realsense-emitter``: a D400's projector on through the window, off outside it;
- ``orbbec``: OrbbecSDK v2 software triggering, one capture per active slot.

``INPUT`` names the sync input's behaviour (``SYNC_INPUTS``): ``l515`` (the default; the line held high
through the window, 60 ms early), ``d400`` (genlock: a 100 us pulse per frame) or ``orbbec`` (hardware
triggering: a pulse per frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from d2sr.errors import ConfigError
from d2sr.triggers.base import Actuator, Pulse, SlotClock, device_window

__all__ = [
    "SYNC_INPUTS",
    "TRIGGERS",
    "Actuator",
    "Pulse",
    "SlotClock",
    "SyncInput",
    "device_window",
    "open_trigger",
    "parse_trigger",
]


@dataclass(frozen=True)
class SyncInput:
    """How a camera's sync input wants to be driven: ``pulse_s`` 0 holds the line through the window, else a
    pulse per frame; ``lead``: slots early; ``latency_s``: slot start to frame on the host; ``rs_mode``:
    the ``inter_cam_sync_mode`` that makes a RealSense wait for it (librealsense's sync white papers)."""

    name: str
    pulse_s: float
    lead: int
    latency_s: float
    about: str
    rs_mode: float | None = None


SYNC_INPUTS = {
    s.name: s
    for s in (
        SyncInput(
            "l515", 0.0, 2, 0.116, "held high 60 ms + 33 ms a frame, 3.3 V; first frame 110-122 ms on", 1
        ),
        SyncInput("d400", 100e-6, 0, 0.05, "genlock: a 100 us pulse per frame, 1.8 V", 4),
        SyncInput("orbbec", 1e-3, 0, 0.05, "hardware triggering: a pulse per frame on the sync connector"),
    )
}

#: Trigger kinds and what each needs.
TRIGGERS = {
    "serial": "serial:PORT[@INPUT] - a microcontroller on USB pulses the sync input (pyserial)",
    "gpio": "gpio:CHIP:LINE[@INPUT] - a host pin pulses the sync input (gpiod, libgpiod v2)",
    "realsense-emitter": "realsense-emitter - a D400's projector on through the window (pyrealsense2)",
    "orbbec": "orbbec - OrbbecSDK v2 software triggering (pyorbbecsdk2)",
}


def parse_trigger(spec: str) -> tuple[str, str, SyncInput]:
    """``KIND[:ARG][@INPUT]`` -> (kind, arg, sync input), or a ConfigError."""
    body, at, name = spec.rpartition("@") if "@" in spec else (spec, "", "")
    sync = SYNC_INPUTS["l515"]
    if at:
        if name not in SYNC_INPUTS:
            raise ConfigError(
                f"trigger {spec!r}: unknown sync input {name!r}; choose from {', '.join(SYNC_INPUTS)}"
            )
        sync = SYNC_INPUTS[name]
    kind, _, arg = body.partition(":")
    if kind not in TRIGGERS:
        raise ConfigError(f"unknown trigger {kind!r}; choose from {', '.join(TRIGGERS)}")
    if kind in ("serial", "gpio") and not arg:
        raise ConfigError(
            f"trigger {kind!r} needs its {'PORT' if kind == 'serial' else 'CHIP:LINE'}: {TRIGGERS[kind]}"
        )
    if kind == "gpio" and len(arg.split(":")) != 2:
        raise ConfigError(f"trigger gpio needs CHIP:LINE, got {arg!r}")
    if kind in ("realsense-emitter", "orbbec") and (arg or at):
        raise ConfigError(f"trigger {kind!r} takes no argument: {TRIGGERS[kind]}")
    return kind, arg, sync


def open_trigger(spec: str, active_frames: int, **options: Any) -> Actuator:
    """The actuator ``spec`` names, for windows of ``active_frames`` slots. ``options`` go to its class
    (e.g. ``latency_s``). The camera-bound kinds (``realsense-emitter``, ``orbbec``) reach a camera once
    given one (``attach``, ``device``)."""
    kind, arg, sync = parse_trigger(spec)
    line = {"pulse_s": sync.pulse_s, "lead": sync.lead, "latency_s": sync.latency_s}
    if kind == "serial":
        from d2sr.triggers.usb_serial import SerialActuator

        return SerialActuator(active_frames, port=arg, **{**line, **options})
    if kind == "gpio":
        from d2sr.triggers.gpio import GpioActuator

        chip, number = arg.split(":")
        return GpioActuator(active_frames, chip=chip, line=number, **{**line, **options})
    if kind == "realsense-emitter":
        from d2sr.triggers.emitter import EmitterActuator

        return EmitterActuator(active_frames, **options)
    from d2sr.triggers.orbbec import OrbbecActuator

    return OrbbecActuator(active_frames, **options)
