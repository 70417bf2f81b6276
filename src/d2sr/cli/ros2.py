"""``d2sr ros2``: the ROS 2 node (Cyclone DDS, no ROS install)."""

from __future__ import annotations

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
    SceneOpt,
    Threshold,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
from d2sr.runtime.settings import DEFAULT_ACTIVE
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
    from d2sr.ros2.serve import serve, summary

    given = {
        k for k in ctx.params if (src := ctx.get_parameter_source(k)) is not None and src.name != "DEFAULT"
    }
    for line in summary(serve(ctx.params, params_file, given, say=print_line)):
        print_line(line)
