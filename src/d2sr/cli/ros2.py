"""``d2sr ros2``: the ROS 2 node (Cyclone DDS, no ROS install)."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Annotated

import typer

from d2sr.cli.common import (
    ActiveFrames,
    MaskLogit,
    ModelDir,
    ModelName,
    Passes,
    RepairOpt,
    SceneFromOpt,
    SceneOpt,
    Threshold,
    TriggerOpt,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.contract.repair import REPAIR_PASSES
from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
from d2sr.runtime.settings import DEFAULT_ACTIVE, RunSettings
from d2sr.ui import print_line

__all__ = ["ros2"]


def ros2(
    ctx: typer.Context,
    topic: Annotated[
        str | None, typer.Option(help="Depth image topic to repair (sensor_msgs/Image); or in --params-file.")
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
    trigger: TriggerOpt = None,
    colour_topic: Annotated[
        str | None,
        typer.Option(
            help="Colour topic (bgr8/rgb8/mono8, depth aligned to it): each colour frame with no depth frame "
            "of its stamp gets a synthesized one on TOPIC/repaired (TOPIC/confidence, status synthesized)."
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
    passes: Passes = REPAIR_PASSES,
    seconds: Annotated[float | None, typer.Option(help="Stop after this long (default: at Ctrl-C).")] = None,
    scene: SceneOpt = True,
    scene_from: SceneFromOpt = None,
    params_file: Annotated[
        Path | None,
        typer.Option(
            help="A ROS 2 parameters file (NODE_NAME: ros__parameters: ..., or /**): any option above, "
            "named with _; a flag given here wins."
        ),
    ] = None,
) -> None:
    """Subscribe to a depth topic and publish TOPIC/repaired (same encoding and header), TOPIC/mask (mono8,
    255 = repaired) and TOPIC/status (diagnostic_msgs/DiagnosticStatus: score, flag, window). Honours
    ROS_DOMAIN_ID; takes reliable and best-effort publishers. Ctrl-C stops it (exit 0).

    Example: ROS_DOMAIN_ID=3 d2sr ros2 --topic /camera/depth/image_rect_raw --trigger serial:/dev/ttyACM0
    """
    from d2sr.errors import ConfigError
    from d2sr.ros2 import Ros2Node, Wire

    if params_file is not None:
        from d2sr.ros2.params import read_params

        o = dict(ctx.params)
        for key, value in read_params(params_file, node_name).items():
            source = ctx.get_parameter_source(key)
            if source is None or source.name == "DEFAULT":  # a flag on the command line wins
                o[key] = value
        topic, depth_scale, qos, transport, node_name = (
            o[k] for k in ("topic", "depth_scale", "qos", "transport", "node_name")
        )
        trigger, colour_topic, controller, active_frames = (
            o[k] for k in ("trigger", "colour_topic", "controller", "active_frames")
        )
        repair, model, models, threshold, mask_logit = (
            o[k] for k in ("repair", "model", "models", "threshold", "mask_logit")
        )
        passes, seconds, scene, scene_from = (o[k] for k in ("passes", "seconds", "scene", "scene_from"))
        namespace = o["namespace"]
    streams: tuple[tuple[str, str], ...] = ()
    if params_file is not None:
        streams = tuple((k[: -len("_qos")], v) for k, v in sorted(o.items()) if k.endswith("_qos") and v)
    if topic is None:
        raise ConfigError("--topic is required (or topic in --params-file)")
    if seconds is not None and not (0 < seconds < float("inf")):
        raise ConfigError(f"--seconds must be a positive number, got {seconds}")
    settings = RunSettings(
        repair=repair, model=model, models=Path(models), threshold=threshold, mask_logit=mask_logit,
        passes=passes, scene=scene, scene_from=scene_from,
    )  # fmt: skip
    wire = Wire(qos=qos, transport=transport, node_name=node_name, namespace=namespace, streams=streams)
    node = Ros2Node(
        topic, depth_scale, wire, say=print_line, colour_topic=colour_topic, controller=controller,
        active_frames=active_frames, trigger=trigger, settings=settings,
    )  # fmt: skip
    signal.signal(signal.SIGINT, lambda *_: node.stop())
    signal.signal(signal.SIGTERM, lambda *_: node.stop())
    t = node.topic
    print_line(f"d2sr ros2: {t} -> {t}/repaired, {t}/mask, {t}/status (ROS_DOMAIN_ID {node.domain})")
    try:
        stats = node.spin(seconds)
    finally:
        node.close()
    lat = stats.latency_ms()
    timing = (
        f"; in the node {lat['median']:.1f} ms median, {lat['p99']:.1f} ms p99" if stats.published else ""
    )
    print_line(
        f"{stats.received} frames in, {stats.published} out ({stats.flagged} flagged, {stats.refused} "
        f"skipped, {stats.dropped} dropped while behind, {stats.synthesized} synthesized){timing}"
    )
