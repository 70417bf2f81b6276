"""``d2sr run``: the three stages together on a simulated room, a recording or a live RealSense."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.progress import TaskID

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
    PrimeOpt,
    RepairOpt,
    RerunOpt,
    Scale,
    ScaleWrong,
    SceneFromOpt,
    SceneRepairOpt,
    Threshold,
    Topic,
    TriggerOpt,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.jobs.stats import stats_table
from d2sr.runtime.settings import DEFAULT_ACTIVE, PRIME_FRAMES, LoopSettings, RunSettings
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
    passes: Passes = None,
    depth_scale: Scale = None,
    recording_scale_wrong: ScaleWrong = False,
    topic: Topic = None,
    backend: BackendOpt = "auto",
    models: ModelDir = WEIGHTS,
    threads: Annotated[
        int | None,
        typer.Option(
            help="onnxruntime threads per model (default: the detector on one core, the repair on all)."
        ),
    ] = None,
    scene_repair: SceneRepairOpt = None,
    scene_from: SceneFromOpt = None,
    prime: PrimeOpt = PRIME_FRAMES,
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
    report: Annotated[
        bool,
        typer.Option(
            "--report/--no-report",
            help="Write report.html into the run folder: what was flagged and repaired, and why.",
        ),
    ] = True,
    max_range: MaxRange = PLAUSIBLE_M[1],
    rerun: RerunOpt = None,
    overwrite: Overwrite = False,
) -> None:
    """Detect every frame, de-synchronize (closed loop where a trigger exists), repair, write it all.

    A recording is replayed open loop (no trigger: the controller's offsets are logged); a killed run
    resumes where it stopped. A simulated room always starts clean.

    Example: d2sr run sim --sensors 3 --seconds 20 --out out/run --rerun out/run.rrd
    """
    from d2sr.jobs.runner import run as run_source

    given: dict[str, Any] = {} if scene is None else {"scene": scene}  # unset: on except for 'sim'
    settings = RunSettings(
        model=model, models=models, backend=backend, repair=repair, threshold=threshold,
        mask_logit=mask_logit, passes=passes, depth_scale=depth_scale, max_range=max_range, topic=topic,
        threads=threads, int8=int8, scene_repair=scene_repair, prime=prime, scene_from=scene_from,
        recording_scale_wrong=recording_scale_wrong, **given,
    )  # fmt: skip
    loop = LoopSettings(
        controller=controller, active_frames=active_frames, seed=seed, sensors=sensors, seconds=seconds,
        moving=moving, trigger=trigger, fill=fill, colour_topic=colour_topic, report=report,
    )  # fmt: skip
    with progress_bar() as bar:
        tasks: dict[str, TaskID] = {}

        def progress(what: str, done: float) -> None:
            if what not in tasks:  # one bar a job (setdefault would add one every call)
                tasks[what] = bar.add_task(what, total=1.0)
            bar.update(tasks[what], completed=done)

        summary = run_source(source, out, settings, loop, rerun=rerun, overwrite=overwrite, progress=progress)
    console.print(stats_table(summary, f"d2sr run {source}"))
    if fill:
        made = ", ".join(str(n) for n in summary["synthesized"])
        console.print(f"synthesized for the slots without a frame, per sensor: {made}")
    console.print(f"-> {out}")
