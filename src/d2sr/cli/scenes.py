"""``d2sr scene``: a still sensor's scene, learned once from a clean recording and stored."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from d2sr.cli.common import Input, MaxRange, Overwrite, Scale, ScaleWrong, Topic
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.runtime.settings import RunSettings
from d2sr.ui import print_line

__all__ = ["learn"]


def learn(
    clean: Input,
    out: Annotated[Path, typer.Option(help="The scene file to write (.npz).")],
    depth_scale: Scale = None,
    recording_scale_wrong: ScaleWrong = False,
    topic: Topic = None,
    max_range: MaxRange = PLAUSIBLE_M[1],
    overwrite: Overwrite = False,
) -> None:
    """Learn a still sensor's scene from a clean recording (the room before the other sensors start) and
    store it in one file; --scene-from SCENE on detect, recover, run and ros2 starts from it.

    Example: d2sr scene learn clean_room/ --depth-scale 4000 --out room.npz
    """
    from d2sr.jobs.scenes import learn_scene_recording

    settings = RunSettings(
        recording_scale_wrong=recording_scale_wrong, depth_scale=depth_scale, topic=topic, max_range=max_range
    )
    s = learn_scene_recording(clean, out, settings, overwrite=overwrite, say=print_line)
    h, w = s.shape
    print_line(
        f"scene of {s.frames} clean frames, {w}x{h} at {s.depth_scale:g} units per metre; "
        f"{s.trusted():.0%} of its pixels returned in 90% of them -> {out}"
    )
