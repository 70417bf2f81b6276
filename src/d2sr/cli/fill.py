"""``d2sr fill``: the frames a duty-cycled sensor's laser skipped, synthesized."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from d2sr.cli.common import Input, Overwrite, Scale, Topic
from d2sr.ui import print_line, progress_bar

__all__ = ["fill"]


def fill(
    input: Input,
    active_frames: Annotated[int, typer.Option(help="Frames kept per 30 (the laser's window).")],
    out: Annotated[Path, typer.Option(help="Output folder: every frame, confidence/, fill.csv.")],
    offset: Annotated[int, typer.Option(help="First kept slot of every 30.")] = 0,
    colour: Annotated[
        Path | None,
        typer.Option(help="Colour frames (.png/.jpg), paired with the depth frames in name order."),
    ] = None,
    depth_scale: Scale = None,
    topic: Topic = None,
    overwrite: Overwrite = False,
) -> None:
    """Keep the frames of slots OFFSET .. OFFSET+N-1 of every 30 exactly as they are and synthesize every
    other frame under its own name: the last kept frame moved to where the camera went (from the colour
    frames), or held when there is no colour. Holes the move uncovers are filled from the background for a
    few pixels with a lower confidence (confidence/<frame>.png, 255 = measured) or left empty.

    Example: d2sr fill d435/ --colour d435/rgb --active-frames 6 --out filled/
    """
    from d2sr.synth import FillSettings, fill_recording

    settings = FillSettings(
        active_frames=active_frames, offset=offset, colour=colour, depth_scale=depth_scale, topic=topic
    )
    with progress_bar() as bar:
        task = bar.add_task(f"{input.name}: filling", total=None)
        summary = fill_recording(
            input, out, settings, overwrite=overwrite, say=print_line,
            progress=lambda done, total: bar.update(task, completed=done, total=total),
        )  # fmt: skip
    print_line(
        f"{summary.frames} frames: {summary.kept} kept, {summary.synthesized} synthesized ({summary.method}; "
        f"intrinsics {summary.intrinsics}) -> {summary.out}"
    )
