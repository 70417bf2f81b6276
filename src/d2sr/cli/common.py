"""Helpers and option types shared by the CLI's command modules."""

from __future__ import annotations

import contextlib
import queue
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Annotated, TypeVar

import numpy as np
import typer

from d2sr.atomic import atomic_dir, check_out
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame, Reader, check_depth, open_frames, to_metres
from d2sr.frames.base import KNOWN_SCALES, PLAUSIBLE_M, probe
from d2sr.ui import console, warn

__all__ = [
    "BackendOpt",
    "Cache",
    "Input",
    "MaxRange",
    "Overwrite",
    "Real",
    "RerunOpt",
    "Scale",
    "Topic",
    "Weights",
    "checked",
    "checked_counts",
    "checked_frames",
    "int_list",
    "open_input",
    "out_dir",
    "prefetch",
    "renamed",
    "resolution_of",
    "split_list",
]

Scale = Annotated[
    float | None,
    typer.Option(help="Units per metre (default: what the recording says, else 1000; raw L515 is 4000)."),
]
Input = Annotated[Path, typer.Argument(help="PNG folder of depth frames or any recording.", metavar="INPUT")]
Topic = Annotated[str | None, typer.Option(help="Depth topic in a ROS bag.")]
BackendOpt = Annotated[str, typer.Option(help="auto (onnxruntime when installed), onnx or torch.")]
Weights = Annotated[Path, typer.Option(help="Folder with the models (safetensors and/or ONNX).")]
# detect, recover and run: --models is the name d2sr adapt's folders are used by
ModelDir = Annotated[
    Path,
    typer.Option("--models", "--weights", help="Folder of models (safetensors, ONNX; d2sr adapt makes one)."),
]
Real = Annotated[Path, typer.Option(help="Folder with the L515 captures dev0/ and dev1/.")]
MaskLogit = Annotated[
    float | None,
    typer.Option(
        help="Recovery mask threshold as a logit: lower repairs more pixels (fills more dropouts, touches "
        "more clean ones). Default: the model's own, chosen on validation frames."
    ),
]
Passes = Annotated[
    int,
    typer.Option(
        help="Runs of the recovery model per frame: each run after the first sees the last one's repair "
        "(finds more of a wide wrong surface; 1 is fastest). A run that repairs nothing ends it early."
    ),
]
Overwrite = Annotated[
    bool,
    typer.Option(
        "--overwrite",
        metavar="",
        help="Replace what d2sr wrote at --out before; files d2sr did not make there are kept.",
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


def open_input(
    path: Path,
    topic: str | None,
    scale: float | None,
    what: str,
    default: float | None = None,
    max_range: float = PLAUSIBLE_M[1],
) -> tuple[Reader, float]:
    """A non-empty recording and its depth scale: ``scale`` if given, else what the recording says, else
    ``default`` (None: the user must say). Frames sampled through it are checked before any work (values,
    size, a scale that makes indoor sense); the scale used and where it came from are printed."""
    reader = open_frames(path, topic=topic)
    notes = []  # warnings wait until every check passed: an error stays the only line
    if scale is not None:
        use, source = scale, "--depth-scale"
        if reader.depth_scale and abs(reader.depth_scale - scale) > 1e-6 * scale:
            notes.append(f"it says its depth scale is {reader.depth_scale:g}; using --depth-scale {scale:g}")
    elif reader.depth_scale:
        use, source = reader.depth_scale, "from the recording"
    else:
        if default is None:
            raise InputError(f"{path}: the recording does not say its depth scale; pass --depth-scale")
        use, source = default, f"default: {KNOWN_SCALES.get(default, 'given')}"
    if not (np.isfinite(use) and use > 0):
        raise InputError(f"--depth-scale must be a positive number, got {use}")
    if not (np.isfinite(max_range) and max_range > PLAUSIBLE_M[0]):
        raise InputError(f"--max-range must be a number of metres above {PLAUSIBLE_M[0]}, got {max_range}")
    if len(reader) == 0:
        raise InputError(f"{path}: the {what} sequence is empty")
    for w in notes + probe(reader.sample(SAMPLED), float(use), max_range):
        warn(f"{path}: {w}")
    console.print(
        f"{path}: {len(reader)} frames, depth scale {use:g} units per metre ({source})", soft_wrap=True
    )
    return reader, float(use)


SAMPLED = 12  # frames checked before a recording is processed


def _metres(f: Frame, scale: float) -> np.ndarray:
    return to_metres(f.depth, 1.0 if f.depth.dtype == np.float32 else scale)


def checked(reader: Iterable[Frame], scale: float) -> Iterator[Frame]:
    """Frames whose values pass ``check_depth`` (the scale was checked by ``open_input``); frames with no
    valid depth are counted and named in one warning at the end."""
    empty: list[str] = []
    count = 0
    for f in reader:
        check_depth(f.depth, f"frame {f.name}")
        count += 1
        if not f.depth.any():
            empty.append(f.name)
        yield f
    if empty:
        warn(
            f"{len(empty)} of {count} frames have no valid depth (e.g. {empty[0]}); "
            "they pass through as they are"
        )


def checked_counts(reader: Iterable[Frame], scale: float, what: str) -> Iterator[Frame]:
    """``checked`` frames that must be 16-bit counts (commands that write or label 16-bit PNGs)."""
    for f in checked(reader, scale):
        if f.depth.dtype != np.uint16:
            raise InputError(f"{what} {f.name} is {f.depth.dtype}; this command needs 16-bit depth")
        yield f


def checked_frames(reader: Iterable[Frame], scale: float) -> Iterator[tuple[Frame, np.ndarray]]:
    """``checked`` frames with their depth in metres."""
    for f in checked(reader, scale):
        yield f, _metres(f, scale)


def prefetch(items: Iterable[T], depth: int = 4) -> Iterator[T]:
    """Produce ``items`` on a thread, ``depth`` ahead (PNG decoding releases the GIL, so reading overlaps
    inference), re-raising its errors here."""
    q: queue.Queue = queue.Queue(depth)
    done = object()

    def run() -> None:
        try:
            for it in items:
                q.put(it)
        except BaseException as exc:
            q.put(exc)
        q.put(done)

    threading.Thread(target=run, daemon=True).start()
    while (it := q.get()) is not done:
        if isinstance(it, BaseException):
            raise it
        yield it
