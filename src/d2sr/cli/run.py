"""``d2sr run``: the three stages together on a simulated room, a recording or a live RealSense."""

from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path
from typing import Annotated

import typer

from d2sr.atomic import check_out
from d2sr.cli.common import (
    ActiveFrames,
    BackendOpt,
    ColourTopic,
    MaskLogit,
    MaxRange,
    ModelDir,
    ModelName,
    Overwrite,
    Passes,
    RepairOpt,
    RerunOpt,
    Scale,
    Threshold,
    Topic,
    TriggerOpt,
)
from d2sr.contract import DEFAULT_MODEL, REPAIR_PASSES, WEIGHTS
from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER, TOTAL_FRAMES
from d2sr.errors import ConfigError, InputError
from d2sr.frames import open_colours
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.frames.checks import Checked, open_input
from d2sr.runtime.live import CAMERAS, check_camera, run_live
from d2sr.runtime.memory import reuse_freed_memory
from d2sr.runtime.pipeline import DEFAULT_ACTIVE, check_options
from d2sr.runtime.stats import stats_table
from d2sr.ui import console, progress_bar

__all__ = ["run"]


def run(
    source: Annotated[
        str,
        typer.Argument(
            help="'sim' (a simulated room), 'realsense[:SERIAL]' / 'orbbec[:SERIAL]' (live) or a recording.",
            metavar="SOURCE",
        ),
    ],
    out: Annotated[Path, typer.Option(help="Output folder: sensor<i>/depth, sensor<i>/masks, log.csv.")],
    controller: Annotated[
        str, typer.Option(help=f"Controller: {', '.join(CONTROLLERS)}.")
    ] = DEFAULT_CONTROLLER,
    active_frames: ActiveFrames = DEFAULT_ACTIVE,
    sensors: Annotated[int, typer.Option(help="sim: sensors in the room.")] = 3,
    seconds: Annotated[float, typer.Option(help="sim / live: seconds to run.")] = 20.0,
    moving: Annotated[bool, typer.Option(metavar="", help="sim: the last sensor rides a robot.")] = False,
    repair: RepairOpt = "flagged",
    trigger: TriggerOpt = None,
    model: ModelName = DEFAULT_MODEL,
    threshold: Threshold = None,
    mask_logit: MaskLogit = None,
    passes: Passes = REPAIR_PASSES,
    depth_scale: Scale = None,
    topic: Topic = None,
    backend: BackendOpt = "auto",
    models: ModelDir = WEIGHTS,
    threads: Annotated[
        int | None,
        typer.Option(
            help="onnxruntime threads per model (default: the detector on one core, the repair on all)."
        ),
    ] = None,
    scene: Annotated[
        bool | None,
        typer.Option(
            "--scene/--no-scene",
            help="A recording's or a camera's frames are also judged against the scene the sensor's clean "
            "frames have shown, while it holds still (on by default; not for 'sim'). --no-scene: the "
            "detector alone.",
        ),
    ] = None,
    fill: Annotated[
        bool,
        typer.Option(
            "--fill",
            metavar="",
            help="Also write a frame for every slot the laser skipped, synthesized from the last frame and "
            "where the camera went, with its confidence (docs/fill.md). sim: from odometry; a bag: every "
            "colour frame of --colour-topic with no depth frame of its stamp; a camera: every colour frame "
            "that comes without depth.",
        ),
    ] = False,
    colour_topic: ColourTopic = None,
    int8: Annotated[
        bool,
        typer.Option(
            "--int8",
            metavar="",
            help="int8 models (d2sr export --int8). Experimental: on real L515 frames their detector's "
            "verdict differed from fp32's on 31 of 60 (docs/results/int8_real.json).",
        ),
    ] = False,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    max_range: MaxRange = PLAUSIBLE_M[1],
    rerun: RerunOpt = None,
    overwrite: Overwrite = False,
) -> None:
    """Detect every frame, de-synchronize (closed loop where a trigger exists), repair, write it all.

    A recording is replayed open loop (no trigger: the controller's offsets are logged); a killed run
    resumes where it stopped. A simulated room always starts clean.

    Example: d2sr run sim --sensors 3 --seconds 20 --out out/run --rerun out/run.rrd
    """
    from d2sr.runtime import session
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.viewer import LIVE, RerunLog

    if controller not in CONTROLLERS:
        raise ConfigError(f"--controller: unknown {controller!r}; choose from {', '.join(CONTROLLERS)}")
    if controller == "oracle" and source != "sim":
        raise ConfigError("--controller oracle needs the simulated world's global knowledge (source 'sim')")
    check_options(model, repair, threshold, "--")
    if not 1 <= active_frames <= TOTAL_FRAMES:
        raise ConfigError(f"--active-frames must be in 1..{TOTAL_FRAMES}, got {active_frames}")
    if not seconds > 0:
        raise ConfigError(f"--seconds must be positive, got {seconds}")
    is_live = source.partition(":")[0] in CAMERAS
    is_recording = source != "sim" and not is_live
    if colour_topic is not None and not (fill and is_recording):
        raise ConfigError("--colour-topic is a bag's colour stream for --fill")
    if fill and is_recording and colour_topic is None:
        raise ConfigError(
            "--fill on a recording needs its colour stream (--colour-topic, a bag's); a recording with every "
            "frame: d2sr fill"
        )
    if scene and source == "sim":
        raise ConfigError("--scene judges a recording's or a camera's frames against its scene; not 'sim'")
    scene = source != "sim" if scene is None else scene
    if trigger is not None and not is_live:
        raise ConfigError("--trigger needs a live camera (realsense[:SERIAL] or orbbec[:SERIAL])")
    if is_live:
        check_camera(source, trigger, fill)
    if source == "sim" and not 1 <= sensors <= 63:
        raise ConfigError(f"--sensors must be in 1..63, got {sensors}")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[Path(source)] if is_recording else [])
    if rerun is not None and rerun != LIVE:
        inputs = [Path(source)] if is_recording else []
        check_out(Path(rerun), is_dir=False, overwrite=overwrite, inputs=inputs, option="--rerun")
    reuse_freed_memory()
    net = open_backend(
        model if repair != "none" else None,
        backend,
        models,
        threads=threads,
        int8=int8,
        mask_logit=mask_logit,
        passes=passes,
    )
    if is_recording:
        path = Path(source)
        if not path.exists():
            raise InputError(f"{source}: no such recording (or use 'sim' / 'realsense')")
        reader, scale = open_input(path, topic, depth_scale, "input", 1000.0, max_range)
        colours = open_colours(path, colour_topic) if colour_topic is not None else None
    shown = sensors if source == "sim" else 1
    with (
        RerunLog(rerun, shown, f"d2sr run {source}") if rerun else nullcontext() as log,
        progress_bar() as bar,
    ):
        on_result = log.write if log is not None else None
        if source == "sim":
            task = bar.add_task(f"{sensors} sensors, {controller} ({net.name})", total=1.0)
            summary = session.run_sim(
                net, out, controller, sensors, seconds, active_frames, seed, moving, repair, threshold,
                progress=lambda f: bar.update(task, completed=f), on_result=on_result, fill=fill,
            )  # fmt: skip
        elif is_live:
            summary = run_live(
                net, out, source, trigger, controller, seconds, active_frames, repair, threshold, seed,
                on_result=on_result, scene=scene, fill=fill,
            )  # fmt: skip
        else:
            task = bar.add_task(f"{path.name} ({net.name})", total=1.0)
            summary = session.run_recording(
                net, Checked(reader, scale), scale, out, controller, str(path.resolve()), active_frames,
                repair, threshold, seed, progress=lambda f: bar.update(task, completed=f),
                on_result=on_result, scene=scene, colours=colours, intrinsics=reader.intrinsics,
            )  # fmt: skip
    console.print(stats_table(summary, f"d2sr run {source}"))
    if fill:
        made = ", ".join(str(n) for n in summary["synthesized"])
        console.print(f"synthesized for the slots without a frame, per sensor: {made}")
    console.print(f"-> {out}")
