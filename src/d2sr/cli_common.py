"""Helpers and option types shared by the CLI's command modules."""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Annotated, TypeVar

import numpy as np
import typer

from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame, check_depth, open_frames, to_metres
from d2sr.frames.base import check_plausible

__all__ = [
    "BackendOpt",
    "Cache",
    "Real",
    "Scale",
    "Topic",
    "Weights",
    "checked",
    "checked_frames",
    "int_list",
    "open_input",
    "prefetch",
    "split_list",
]

Scale = Annotated[
    float | None,
    typer.Option(help="Units per metre (default: what the recording says, else 1000; raw L515 is 4000)."),
]
Topic = Annotated[str | None, typer.Option(help="Depth topic in a ROS bag.")]
BackendOpt = Annotated[str, typer.Option(help="auto (onnxruntime when installed), onnx or torch.")]
Weights = Annotated[Path, typer.Option(help="Folder with the models (safetensors and/or ONNX).")]
Real = Annotated[Path, typer.Option(help="Folder with the L515 captures dev0/ and dev1/.")]
MaskLogit = Annotated[
    float | None,
    typer.Option(
        help="Recovery mask threshold as a logit: lower repairs more pixels (fills more dropouts, touches "
        "more clean ones). Default: the model's own, chosen on validation frames."
    ),
]
T = TypeVar("T")
Cache = Annotated[Path, typer.Option(help="Where generated data sets are kept.")]


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
    path: Path, topic: str | None, scale: float | None, what: str, default: float | None = None
) -> tuple[object, float]:
    """A non-empty recording and its depth scale: ``scale`` if given, else what the recording says, else
    ``default`` (None: the user must say)."""
    reader = open_frames(path, topic=topic)
    use = scale if scale is not None else (reader.depth_scale or default)
    if use is None:
        raise InputError(f"{path}: the recording does not say its depth scale; pass --depth-scale")
    if not (np.isfinite(use) and use > 0):
        raise InputError(f"--depth-scale must be a positive number, got {use}")
    if len(reader) == 0:
        raise InputError(f"{path}: the {what} sequence is empty")
    return reader, float(use)


def _metres(f: Frame, scale: float) -> np.ndarray:
    return to_metres(f.depth, 1.0 if f.depth.dtype == np.float32 else scale)


def checked(reader: Iterable[Frame], scale: float) -> Iterator[Frame]:
    """Checked frames (values; the first frame's scale, ``check_plausible``), for callers that convert
    to metres themselves or never do."""
    first = True
    for f in reader:
        check_depth(f.depth, f"frame {f.name}")
        if first:
            check_plausible(f.name, _metres(f, scale), scale)
            first = False
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
