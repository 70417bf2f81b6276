"""``orbbec``: an Orbbec camera's depth with OrbbecSDK v2's software triggering (``pyorbbecsdk2``): the
camera waits in ``SOFTWARE_TRIGGERING`` mode and captures one frame per ``trigger_capture()``, which the slot
clock calls on each active slot. The mode is set before the pipeline starts. It covers Femto Mega and
Gemini 330 / 2 / 435Le, not Femto Bolt (which needs its sync cable). Install: see docs/hardware.md."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame
from d2sr.triggers.host import HostActuator

__all__ = ["NAMES", "OrbbecActuator", "import_ob", "open_orbbec"]

#: What d2sr calls in the SDK (tested against the installed pyorbbecsdk2).
NAMES = {
    "": ("Context", "Config", "Pipeline", "OBMultiDeviceSyncMode", "OBSensorType", "OBFormat"),
    "OBMultiDeviceSyncMode": ("SOFTWARE_TRIGGERING",),
    "OBMultiDeviceSyncConfig": ("mode", "frames_per_trigger"),
    "Device": ("get_multi_device_sync_config", "set_multi_device_sync_config", "trigger_capture"),
    "Pipeline": ("start", "stop", "wait_for_frames", "get_stream_profile_list"),
    "DeviceList": ("get_count", "get_device_by_index", "get_device_by_serial_number"),
    "DepthFrame": ("get_data", "get_width", "get_height", "get_depth_scale", "get_timestamp_us"),
}


def import_ob() -> Any:
    """pyorbbecsdk, imported without its banner on stdout and with its log files off (it writes ./Log)."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
        try:
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                import pyorbbecsdk
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        pyorbbecsdk.Context.set_logger_to_file(pyorbbecsdk.OBLogLevel.NONE, "")
        pyorbbecsdk.Context.set_logger_to_console(pyorbbecsdk.OBLogLevel.NONE)
    except ImportError:
        raise InputError(
            "Orbbec cameras need pyorbbecsdk2: install 'pyorbbecsdk2>=2.1' without its dependencies "
            "(docs/hardware.md)"
        ) from None
    return pyorbbecsdk


def open_orbbec(serial: str | None, triggered: bool) -> tuple[Any, Any]:
    """(device, pipeline) of the Orbbec camera ``serial`` (None: the first), in software-triggering mode when
    ``triggered``; the depth stream is enabled, not started."""
    ob = import_ob()
    devices = ob.Context().query_devices()
    if devices.get_count() == 0:
        raise InputError("no Orbbec device connected")
    try:
        device = devices.get_device_by_serial_number(serial) if serial else devices.get_device_by_index(0)
    except Exception as exc:  # the SDK raises its own OBError
        raise InputError(f"no Orbbec with serial {serial} ({exc})") from None
    if triggered:
        cfg = device.get_multi_device_sync_config()
        cfg.mode = ob.OBMultiDeviceSyncMode.SOFTWARE_TRIGGERING
        cfg.frames_per_trigger = 1
        try:
            device.set_multi_device_sync_config(cfg)
        except Exception as exc:
            raise InputError(f"this Orbbec camera has no software triggering ({exc})") from None
    return device, ob.Pipeline(device)


def orbbec_frames(pipe: Any, seconds: float) -> Iterator[tuple[Frame, float, float]]:
    """(frame, scale in units per metre, host arrival time) for ``seconds`` from a started pipeline."""
    ob = import_ob()
    config = ob.Config()
    profiles = pipe.get_stream_profile_list(ob.OBSensorType.DEPTH_SENSOR)
    config.enable_stream(profiles.get_default_video_stream_profile())
    pipe.start(config)
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            frames = pipe.wait_for_frames(100)
            depth = frames.get_depth_frame() if frames is not None else None
            if depth is None:
                continue
            # the SDK's system (host) timestamp of the frame, on time.monotonic: a lagging loop would
            # otherwise stamp queued frames late and put them in later slots
            arrival = time.monotonic() - (time.time() - depth.get_system_timestamp_us() / 1e6)
            h, w = depth.get_height(), depth.get_width()
            data = np.frombuffer(depth.get_data(), np.uint16).reshape(h, w).copy()
            scale = 1000.0 / float(depth.get_depth_scale())  # the SDK gives millimetres per unit
            stamp = int(depth.get_timestamp_us()) * 1000
            yield Frame(f"{depth.get_index():08d}", data, stamp), scale, arrival
    finally:
        pipe.stop()


@dataclass
class OrbbecActuator(HostActuator):
    """One ``trigger_capture()`` per active slot of the controller's window on ``device``."""

    pulse_s: float = 0.001
    kind: str = "orbbec"
    device: Any = None
    latency_s: float = 0.05  # no figure is published; a stated guess until measured on hardware

    def __post_init__(self) -> None:
        self.write = self._fire
        super().__post_init__()

    @property
    def unbound(self) -> str | None:
        """What this trigger still needs before it acts on anything (None: nothing)."""
        return "an Orbbec device (attach(device))" if self.device is None else None

    def attach(self, device: Any) -> None:
        """Fire this device's software trigger from now on."""
        self.device = device

    def _fire(self, level: int) -> None:
        if level and self.device is not None:
            self.device.trigger_capture()
