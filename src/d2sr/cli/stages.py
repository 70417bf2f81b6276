"""``d2sr detect`` and ``d2sr recover``: options parsed here, the work done by ``d2sr.jobs.recordings``."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer

from d2sr.cli.common import (
    BackendOpt,
    ColourTopic,
    Input,
    MaskLogit,
    MaxRange,
    ModelDir,
    ModelName,
    Overwrite,
    Passes,
    PrimeOpt,
    RecoverRepairOpt,
    RerunOpt,
    Scale,
    ScaleWrong,
    SceneFromOpt,
    SceneOpt,
    SceneRepairOpt,
    Threshold,
    Topic,
    repair_of,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.jobs.recordings import Progress
from d2sr.runtime.settings import PRIME_FRAMES, RunSettings
from d2sr.ui import print_line, progress_bar

__all__ = ["detect", "recover"]


@contextmanager
def _bar(what: str) -> Iterator[Progress]:
    """A progress bar the library's jobs advance: (frames done, frames in all)."""
    with progress_bar() as bar:
        task = bar.add_task(what, total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


def detect(
    input: Input,
    out: Annotated[
        Path,
        typer.Option(
            help="CSV file with the columns frame, score, interfered and reason (why: detector, scene, "
            "detector+scene or "
            "cleared by scene)."
        ),
    ],
    depth_scale: Scale = None,
    recording_scale_wrong: ScaleWrong = False,
    threshold: Threshold = None,
    topic: Topic = None,
    backend: BackendOpt = "auto",
    models: ModelDir = WEIGHTS,
    max_range: MaxRange = PLAUSIBLE_M[1],
    scene: SceneOpt = True,
    scene_from: SceneFromOpt = None,
    prime: PrimeOpt = PRIME_FRAMES,
    overwrite: Overwrite = False,
) -> None:
    """Stage 1: score every frame (probability that it is interfered).

    Example: d2sr detect recording/ --depth-scale 4000 --out flags.csv
    """
    from d2sr.jobs.recordings import detect_recording

    settings = RunSettings(
        recording_scale_wrong=recording_scale_wrong,
        depth_scale=depth_scale, topic=topic, threshold=threshold, models=models, backend=backend,
        max_range=max_range, scene=scene, prime=prime, scene_from=scene_from,
    )  # fmt: skip
    with _bar("detecting") as progress:
        s = detect_recording(input, out, settings, overwrite=overwrite, progress=progress, say=print_line)
    typer.echo(f"{s.flagged} of {s.frames} frames flagged as interfered{s.scene_note()} -> {out}")


def recover(
    input: Input,
    out: Annotated[
        Path,
        typer.Option(
            help="Output: a folder of <name>.png repaired and masks/<name>.png; for a ROS bag, a bag of its "
            "kind with every input topic plus TOPIC/repaired and TOPIC/mask (see --format)."
        ),
    ],
    depth_scale: Scale = None,
    recording_scale_wrong: ScaleWrong = False,
    repair: RecoverRepairOpt = "flagged",
    model: ModelName = DEFAULT_MODEL,
    threshold: Threshold = None,
    mask_logit: MaskLogit = None,
    passes: Passes = None,
    topic: Topic = None,
    format: Annotated[
        str,
        typer.Option(
            help="auto: a ROS 1 or ROS 2 bag gives a bag of its kind (ROS 2 keeps MCAP or sqlite3), anything "
            "else (a RealSense .bag too) a PNG folder; png: always a PNG folder; bag: a bag, or an error."
        ),
    ] = "auto",
    backend: BackendOpt = "auto",
    models: ModelDir = WEIGHTS,
    max_range: MaxRange = PLAUSIBLE_M[1],
    rerun: RerunOpt = None,
    scene: SceneOpt = True,
    scene_from: SceneFromOpt = None,
    scene_repair: SceneRepairOpt = None,
    prime: PrimeOpt = PRIME_FRAMES,
    colour_topic: ColourTopic = None,
    report: Annotated[
        bool,
        typer.Option(
            "--report/--no-report",
            help="Write report.html: the frames flagged and why, and the most changed before and after.",
        ),
    ] = True,
    overwrite: Overwrite = False,
) -> None:
    """Stage 3: repair interfered frames (predicted depth inside the predicted mask, the input outside).
    Frames in time order: a temporal model (unet8-temporal) also sees the last frame the detector passed;
    --model auto (the default) takes it for the frames that line up with that frame (a sensor that held
    still) and unet8 for the others. With --repair all and a temporal model the detector runs only where it
    can change that frame.

    Example: d2sr recover recording/ --depth-scale 4000 --out repaired/
    """
    from d2sr.jobs.recordings import Written, recover_recording

    settings = RunSettings(
        recording_scale_wrong=recording_scale_wrong,
        depth_scale=depth_scale, topic=topic, repair=repair_of(repair), model=model,
        models=models, threshold=threshold, mask_logit=mask_logit, passes=passes, backend=backend,
        max_range=max_range, scene=scene, scene_repair=scene_repair, prime=prime, scene_from=scene_from,
    )  # fmt: skip
    written = Written(format, rerun, colour_topic, overwrite, report)
    with _bar(f"recovering ({model})") as progress:
        s = recover_recording(input, out, settings, written, progress=progress, say=print_line)
    typer.echo(s.line())
    if s.report is not None:
        typer.echo(f"what changed, and why: {s.report}")
