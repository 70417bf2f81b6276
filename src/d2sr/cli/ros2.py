"""``d2sr ros2``: the ROS 2 node (Cyclone DDS, no ROS install)."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Annotated, Any

import typer

from d2sr.cli.common import (
    ActiveFrames,
    MaskLogit,
    ModelDir,
    ModelName,
    Passes,
    RepairOpt,
    SceneOpt,
    Threshold,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
from d2sr.errors import ConfigError
from d2sr.runtime.settings import DEFAULT_ACTIVE, RunSettings
from d2sr.ui import print_line

__all__ = ["ros2"]


def ros2(
    ctx: typer.Context,
    topic: Annotated[
        list[str] | None,
        typer.Option(
            help="Depth image topic to repair (sensor_msgs/Image); repeat it for several cameras in one "
            "process (they share the models); or in --params-file."
        ),
    ] = None,
    depth_scale: Annotated[
        float | None,
        typer.Option(
            help="Units per metre of 16-bit images on the topic (default: 1000, REP 118's millimetres)."
        ),
    ] = None,
    qos: Annotated[
        str, typer.Option(help="Reliability of what the node publishes: reliable or best-effort.")
    ] = ("reliable"),
    transport: Annotated[
        str,
        typer.Option(
            help="How images travel: raw (sensor_msgs/Image on TOPIC) or compressedDepth "
            "(TOPIC/compressedDepth in, TOPIC/repaired/compressedDepth out beside the raw TOPIC/repaired), "
            "as image_transport names them."
        ),
    ] = "raw",
    node_name: Annotated[
        str, typer.Option(help="The node's name, as ros2 node list shows it (namespace /).")
    ] = "d2sr",
    namespace: Annotated[
        str, typer.Option(help="The node's namespace; a relative --topic resolves under it (default /).")
    ] = "/",
    remap: Annotated[
        list[str] | None,
        typer.Option(
            metavar="FROM:=TO",
            help="A ROS 2 remapping rule (as ros2 run takes one after -r): a topic the node reads or "
            "writes, __node or __ns; repeat it for several.",
        ),
    ] = None,
    trigger: Annotated[
        list[str] | None,
        typer.Option(
            metavar="KIND[:ARG]",
            help="What moves the sensor's window (closes the loop): serial:PORT, gpio:CHIP:LINE, "
            "realsense-emitter or orbbec; serial and gpio take @l515 (default), @d400 or @orbbec. With "
            "several --topic, one per topic, in order.",
        ),
    ] = None,
    colour_topic: Annotated[
        list[str] | None,
        typer.Option(
            help="Colour topic (bgr8/rgb8/mono8, depth aligned to it): each colour frame with no depth frame "
            "of its stamp gets a synthesized one on TOPIC/repaired (TOPIC/confidence, status synthesized). "
            "With several --topic, one per topic, in order."
        ),
    ] = None,
    controller: Annotated[
        str, typer.Option(help=f"Controller: {', '.join(c for c in CONTROLLERS if c != 'oracle')}.")
    ] = DEFAULT_CONTROLLER,
    active_frames: ActiveFrames = DEFAULT_ACTIVE,
    repair: RepairOpt = "flagged",
    model: ModelName = DEFAULT_MODEL,
    models: ModelDir = WEIGHTS,
    threshold: Threshold = None,
    mask_logit: MaskLogit = None,
    passes: Passes = None,
    seconds: Annotated[float | None, typer.Option(help="Stop after this long (default: at Ctrl-C).")] = None,
    scene: SceneOpt = True,
    scene_from: Annotated[
        list[Path] | None,
        typer.Option(
            help="A stored scene (d2sr scene learn): the scene starts from it, not from the frames. With "
            "several --topic, one per topic, in order."
        ),
    ] = None,
    params_file: Annotated[
        Path | None,
        typer.Option(
            help="A ROS 2 parameters file (NODE_NAME: ros__parameters: ..., or /**): any option above, "
            "named with _ (a list for a repeated one); a flag given here wins."
        ),
    ] = None,
) -> None:
    """Subscribe to a depth topic and publish TOPIC/repaired (same encoding and header), TOPIC/mask (mono8,
    255 = repaired), TOPIC/status (diagnostic_msgs/DiagnosticStatus: score, flag, window) and
    TOPIC/camera_info; /diagnostics once a second for every camera. Honours ROS_DOMAIN_ID; takes reliable and
    best-effort publishers. Ctrl-C stops it (exit 0).

    Example: ROS_DOMAIN_ID=3 d2sr ros2 --topic /camera/depth/image_rect_raw --trigger serial:/dev/ttyACM0
    """
    from d2sr.ros2 import Ros2Node, Wire, cameras_from

    o = dict(ctx.params)
    if params_file is not None:
        from d2sr.ros2.params import read_params

        for key, value in read_params(params_file, node_name).items():
            source = ctx.get_parameter_source(key)
            if source is None or source.name == "DEFAULT":  # a flag on the command line wins
                o[key] = value
    streams = tuple((k[: -len("_qos")], v) for k, v in sorted(o.items()) if k.endswith("_qos") and v)
    topics = _listed(o["topic"])
    if not topics:
        raise ConfigError("--topic is required (or topic in --params-file)")
    if o["seconds"] is not None and not (0 < o["seconds"] < float("inf")):
        raise ConfigError(f"--seconds must be a positive number, got {o['seconds']}")
    cams = cameras_from(topics, _listed(o["colour_topic"]), _listed(o["trigger"]), _listed(o["scene_from"]))
    settings = RunSettings(
        repair=o["repair"], model=o["model"], models=Path(o["models"]), threshold=o["threshold"],
        mask_logit=o["mask_logit"], passes=o["passes"], scene=o["scene"],
    )  # fmt: skip
    wire = Wire(qos=o["qos"], transport=o["transport"], node_name=o["node_name"], namespace=o["namespace"],
                streams=streams, remaps=tuple(_listed(o["remap"])))  # fmt: skip
    node = Ros2Node(
        cams, o["depth_scale"], wire, say=print_line, controller=o["controller"],
        active_frames=o["active_frames"], settings=settings,
    )  # fmt: skip
    signal.signal(signal.SIGINT, lambda *_: node.stop())
    signal.signal(signal.SIGTERM, lambda *_: node.stop())
    for cam in node.cameras:
        print_line(f"d2sr ros2: {cam.topic} -> {', '.join(cam.outputs)} (ROS_DOMAIN_ID {node.domain})")
    try:
        figures = node.spin(o["seconds"])
    finally:
        node.close()
    for t, stats in figures.items():
        lat = stats.latency_ms()
        timing = (
            f"; in the node {lat['median']:.1f} ms median, {lat['p99']:.1f} ms p99" if stats.published else ""
        )
        print_line(
            f"{t if len(figures) > 1 else ''}{': ' if len(figures) > 1 else ''}{stats.received} frames in, "
            f"{stats.published} out ({stats.flagged} flagged, {stats.refused} skipped, {stats.dropped} "
            f"dropped while behind, {stats.synthesized} synthesized){timing}"
        )


def _listed(value: object) -> list[Any]:
    """An option given once or repeated (or a parameter given as one value or a list), as a list."""
    if value is None:
        return []
    return list(value) if isinstance(value, list | tuple) else [value]
