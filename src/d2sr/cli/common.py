"""Helpers and option types shared by the CLI's command modules."""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Annotated, TypeVar

import typer

from d2sr.atomic import atomic_dir, check_out
from d2sr.contract.catalog import MODEL_HELP
from d2sr.errors import ConfigError
from d2sr.ui import warn

__all__ = [
    "BackendOpt",
    "Cache",
    "Input",
    "MaxRange",
    "ModelDir",
    "ModelName",
    "Overwrite",
    "Real",
    "RecoverRepairOpt",
    "RerunOpt",
    "Scale",
    "SceneOpt",
    "Topic",
    "int_list",
    "out_dir",
    "renamed",
    "repair_of",
    "resolution_of",
    "split_list",
]

Scale = Annotated[
    float | None,
    typer.Option(help="Units per metre (default: what the recording says, else 1000; raw L515 is 4000)."),
]
ScaleWrong = Annotated[
    bool,
    typer.Option(
        "--recording-scale-wrong",
        help="The recording's own depth scale is wrong: --depth-scale replaces it (else a --depth-scale that "
        "contradicts it is refused).",
    ),
]
#: What recover and fleet repair (RunSettings.repair's "none" is for d2sr run).
REPAIRS = ("flagged", "all")
RecoverRepairOpt = Annotated[
    str, typer.Option(help="flagged (default: the frames the detector flags) or all (every frame).")
]


def repair_of(repair: str) -> str:
    """``--repair`` of recover and fleet: one of ``REPAIRS`` (a one-line error naming them otherwise)."""
    if repair not in REPAIRS:
        raise ConfigError(f"--repair: unknown {repair!r}; choose from {', '.join(REPAIRS)}")
    return repair


Input = Annotated[Path, typer.Argument(help="PNG folder of depth frames or any recording.", metavar="INPUT")]
Topic = Annotated[str | None, typer.Option(help="Depth topic in a ROS bag.")]
ColourTopic = Annotated[
    str | None,
    typer.Option(
        help="A ROS bag's colour topic (bgr8/rgb8/mono8 or jpeg/png, depth aligned to it): each colour frame "
        "that no depth frame of its stamp joins (the laser was off) gets a synthesized depth frame."
    ),
]
BackendOpt = Annotated[str, typer.Option(help="auto (onnxruntime when installed), onnx or torch.")]
# A folder of models is --models on every command; one model by name is --model.
ModelDir = Annotated[
    Path,
    typer.Option(
        "--models",
        help="Folder of models (safetensors, ONNX; d2sr adapt makes one). [default: the shipped models]",
        show_default=False,
    ),
]
ModelName = Annotated[str, typer.Option(help=MODEL_HELP)]
Real = Annotated[Path, typer.Option(help="Folder with the L515 captures dev0/ and dev1/.")]
MaskLogit = Annotated[
    float | None,
    typer.Option(
        help="Recovery mask threshold as a logit: lower repairs more pixels (fills more dropouts, touches "
        "more clean ones). Default: the model's own, chosen on validation frames."
    ),
]
Passes = Annotated[
    int | None,
    typer.Option(
        help="Runs of the recovery model per frame: each run after the first sees the last one's repair "
        "(finds more of a wide wrong surface; 1 is fastest). A run that repairs nothing ends it early. "
        "[default: the model's own: 1 for unet8-fast, 2 for the others]",
        show_default=False,
    ),
]
Overwrite = Annotated[
    bool,
    typer.Option(
        "--overwrite",
        metavar="",
        help="Replace outputs d2sr wrote before; a file of yours is never replaced (in a folder, kept).",
    ),
]
MaxRange = Annotated[
    float,
    typer.Option(help="Farthest median scene depth (m) the scale check accepts; raise it for large halls."),
]
RerunOpt = Annotated[
    str | None,
    typer.Option(
        "--rerun",
        help="Also log the run to Rerun: a FILE.rrd to save, or 'live' to spawn (or reach) a viewer. Images "
        "at half resolution (the output folder keeps every pixel).",
        metavar="FILE.rrd|live",
    ),
]
SceneOpt = Annotated[
    bool,
    typer.Option(
        "--scene/--no-scene",
        help="Also judge each frame against the scene the sensor's clean frames have shown, while it holds "
        "still: a flagged frame in which nothing deviates from it passes (a false alarm), one with fresh "
        "patches off it is flagged. --no-scene: the detector alone.",
    ),
]
PrimeOpt = Annotated[
    int,
    typer.Option(
        "--prime",
        help="With the scene: frames of the recording it first learns from, judged backwards, so that the "
        "first frames are judged against a scene too. 0: start cold, as a live sensor does.",
        min=0,
    ),
]
ActiveFrames = Annotated[int, typer.Option(help="Frames per 1 s period (30 slots).")]
RepairOpt = Annotated[str, typer.Option(help="flagged (default), all (worst case) or none.")]
TriggerOpt = Annotated[
    str | None,
    typer.Option(
        metavar="KIND[:ARG]",
        help="What moves the sensor's window (closes the loop): serial:PORT, gpio:CHIP:LINE, "
        "realsense-emitter or orbbec; serial and gpio take @l515 (default), @d400 or @orbbec.",
    ),
]
T = TypeVar("T")
Cache = Annotated[Path, typer.Option(help="Where generated data sets are kept.")]
Threshold = Annotated[
    float | None,
    typer.Option(help="Detector score that flags a frame (default: the detector's own; 0.5 when shipped)."),
]


@contextlib.contextmanager
def out_dir(out: Path, overwrite: bool, inputs: Iterable[Path | None] = ()) -> Iterator[Path]:
    """A temporary folder that becomes ``out`` when the block succeeds (``d2sr.atomic``'s policy: the
    input and files d2sr did not make are never replaced)."""
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs)
    with atomic_dir(out) as tmp:
        yield tmp


def resolution_of(value: str) -> tuple[int, int]:
    """``640x480`` -> (640, 480)."""
    try:
        w, h = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise ConfigError(f"resolution must look like 640x480, got {value!r}") from None
    if w < 16 or h < 16 or w > 4096 or h > 4096:
        raise ConfigError(f"resolution {value} out of range (16..4096 per side)")
    return w, h


def renamed(old: str, new: str, value: T | None, current: T) -> T:
    """A deprecated option's value, if given, with a warning naming the option that replaces it."""
    if value is None:
        return current
    warn(f"{old} is deprecated and will be removed; use {new}")
    return value


def split_list(value: str, what: str, choices: tuple[str, ...] | None = None) -> list[str]:
    items = [v.strip() for v in value.split(",") if v.strip()]
    if not items:
        raise ConfigError(f"--{what} is empty")
    if choices:
        bad = [v for v in items if v not in choices]
        if bad:
            raise ConfigError(f"--{what}: unknown {', '.join(bad)}; choose from {', '.join(choices)}")
    return items


def int_list(value: str, what: str) -> list[int]:
    try:
        return [int(v) for v in split_list(value, what)]
    except ValueError:
        raise ConfigError(f"--{what} takes comma-separated integers, got {value!r}") from None


SceneRepairOpt = Annotated[
    bool | None,
    typer.Option(
        "--scene-repair/--no-scene-repair",
        help="With the scene: where it is trusted, its own depth repairs a frame's fresh deviations, and "
        "the model leaves alone what reads as the scene. [default: on; recover --repair all: off, where it "
        "would have the scene judge every frame]",
        show_default=False,
    ),
]
SceneFromOpt = Annotated[
    Path | None,
    typer.Option(help="A stored scene (d2sr scene learn): the scene starts from it, not from the frames."),
]
