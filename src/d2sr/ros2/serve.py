"""``d2sr ros2`` as one call: its options (a parameters file beneath the flags given), the node built from
them, run until its time is up or a signal stops it, and each camera's figures in a line."""

from __future__ import annotations

import signal
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import Any

from d2sr.errors import ConfigError
from d2sr.jobs.memory import reuse_freed_memory
from d2sr.ros2.camera import Stats
from d2sr.ros2.node import Ros2Node, cameras_from
from d2sr.ros2.wire import Wire
from d2sr.runtime.settings import DesyncSettings, RunSettings

__all__ = ["serve", "summary"]


def _listed(value: object) -> list[Any]:
    """An option given once or repeated (or a parameter given as one value or a list), as a list."""
    if value is None:
        return []
    return list(value) if isinstance(value, list | tuple) else [value]


def _merged(options: Mapping[str, Any], params_file: Path | None, given: Collection[str]) -> dict[str, Any]:
    """``options`` with the parameters file's values for every option not in ``given`` (set on the command
    line, which wins)."""
    o = dict(options)
    if params_file is not None:
        from d2sr.ros2.params import read_params

        for key, value in read_params(params_file, str(o["node_name"])).items():
            if key not in given:
                o[key] = value
    return o


def serve(
    options: Mapping[str, Any],
    params_file: Path | None = None,
    given: Collection[str] = (),
    say: Callable[[str], None] = print,
) -> dict[str, Stats]:
    """Run the node ``d2sr ros2``'s ``options`` describe (its option names with ``_``; ``params_file`` may set
    those not ``given``) until ``options["seconds"]`` pass or SIGINT / SIGTERM stop it; each camera's
    figures by topic. ``say`` gets one line per camera as it starts, and warnings."""
    o = _merged(options, params_file, given)
    streams = tuple((k[: -len("_qos")], v) for k, v in sorted(o.items()) if k.endswith("_qos") and v)
    topics = _listed(o["topic"])
    if not topics:
        raise ConfigError("topic is required (or topic in the parameters file)", "topic")
    if o["seconds"] is not None and not (0 < o["seconds"] < float("inf")):
        raise ConfigError(f"seconds must be a positive number, got {o['seconds']}", "seconds")
    cams = cameras_from(topics, _listed(o["colour_topic"]), _listed(o["trigger"]), _listed(o["scene_from"]))
    settings = RunSettings(
        repair=o["repair"], model=o["model"], models=Path(o["models"]), threshold=o["threshold"],
        mask_logit=o["mask_logit"], passes=o["passes"], scene=o["scene"],
    )  # fmt: skip
    wire = Wire(qos=o["qos"], transport=o["transport"], node_name=o["node_name"], namespace=o["namespace"],
                streams=streams, remaps=tuple(_listed(o["remap"])))  # fmt: skip
    desync = DesyncSettings(controller=o["controller"], active_frames=o["active_frames"])
    # A frame's buffers serve the next instead of faulting in afresh: at 30 Hz with every frame interfered
    # on two cores, the node's p99 fell from about 100 ms to about 68 (lab/notes/decisions.md).
    reuse_freed_memory()
    node = Ros2Node(cams, o["depth_scale"], wire, say=say, settings=settings, desync=desync)
    signal.signal(signal.SIGINT, lambda *_: node.stop())
    signal.signal(signal.SIGTERM, lambda *_: node.stop())
    for cam in node.cameras:
        say(f"d2sr ros2: {cam.topic} -> {', '.join(cam.outputs)} (ROS_DOMAIN_ID {node.domain})")
    try:
        return node.spin(o["seconds"])
    finally:
        node.close()


def summary(figures: Mapping[str, Stats]) -> list[str]:
    """One line per camera: frames in and out, and what became of the others; the time in the node."""
    lines = []
    for t, stats in figures.items():
        lat = stats.latency_ms()
        timing = (
            f"; in the node {lat['median']:.1f} ms median, {lat['p99']:.1f} ms p99" if stats.published else ""
        )
        name = f"{t}: " if len(figures) > 1 else ""
        lines.append(
            f"{name}{stats.received} frames in, {stats.published} out ({stats.flagged} flagged, "
            f"{stats.refused} skipped, {stats.dropped} dropped while behind, {stats.synthesized} "
            f"synthesized){timing}"
        )
    return lines
