"""Depth I/O: one small reader/writer protocol (``base``) and an explicit registry of formats.

=========  ==========================================  ===========================
format     path                                        module
=========  ==========================================  ===========================
png        folder of 16-bit PNGs (+ ``meta.json``)     ``d2sr.frames.png``
npz        ``.npz`` file                               ``d2sr.frames.npz``
ros1       ``.bag`` (ROS 1)                            ``d2sr.frames.rosbag``
ros2       ROS 2 bag folder (.db3 or .mcap inside)     ``d2sr.frames.rosbag``
realsense  RealSense ``.db3`` / ``.bag`` recording     ``d2sr.frames.realsense``
=========  ==========================================  ===========================
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics, Reader, Writer, check_depth, to_metres

__all__ = [
    "FORMATS",
    "Frame",
    "Intrinsics",
    "Reader",
    "Writer",
    "check_depth",
    "detect_format",
    "open_colours",
    "open_frames",
    "open_writer",
    "to_metres",
]


@dataclass(frozen=True)
class Format:
    reader: str
    writer: str
    takes_topic: bool = False

    def load(self, which: str) -> type[Any]:
        module, name = getattr(self, which).split(":")
        cls = getattr(importlib.import_module(module), name)
        assert isinstance(cls, type)
        return cls


FORMATS: dict[str, Format] = {
    "png": Format("d2sr.frames.png:PngReader", "d2sr.frames.png:PngWriter"),
    "npz": Format("d2sr.frames.npz:NpzReader", "d2sr.frames.npz:NpzWriter"),
    "ros1": Format("d2sr.frames.rosbag:BagReader", "d2sr.frames.rosbag:Ros1Writer", takes_topic=True),
    "ros2": Format("d2sr.frames.rosbag:BagReader", "d2sr.frames.rosbag:Ros2Writer", takes_topic=True),
    "realsense": Format("d2sr.frames.realsense:RealSenseReader", "d2sr.frames.realsense:RealSenseWriter"),
}


def _is_realsense_bag(path: Path) -> bool:
    from d2sr.frames.rosbag import bag_topics

    return any(t.startswith("/device_") for t in bag_topics(path))


def detect_format(path: Path) -> str:
    """The format of an existing recording, from its layout (and, for .bag, its topics)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if not (path.is_dir() or path.is_file()):  # a pipe or a device would be read forever
        raise InputError(f"{path}: not a regular file or folder (a pipe or a device?)")
    if path.is_dir():
        if (path / "metadata.yaml").is_file():
            pipes = [p.name for p in path.iterdir() if p.suffix in (".db3", ".mcap") and not p.is_file()]
            if pipes:
                raise InputError(f"{path / pipes[0]}: not a regular file (a pipe or a device?)")
            return "ros2"
        return "png"
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return "npz"
    if suffix in (".db3", ".mcap"):
        return "ros2" if (path.parent / "metadata.yaml").is_file() else "realsense"
    if suffix == ".bag":
        return "realsense" if _is_realsense_bag(path) else "ros1"
    if suffix == ".png":
        raise InputError(f"{path}: give the folder that holds the PNG frames, not one file")
    raise InputError(f"{path}: unknown recording format (expected a PNG folder, .npz, .bag, .db3, .mcap)")


def open_frames(path: Path, topic: str | None = None, format: str | None = None) -> Reader:
    """Open any supported recording for reading. ``topic`` picks a stream in a bag."""
    if not isinstance(path, str | os.PathLike):
        raise InputError(f"a recording is a path, got {type(path).__name__}")
    fmt = format or detect_format(Path(path))
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
    spec = FORMATS[fmt]
    if topic is not None and not spec.takes_topic:
        raise InputError(f"{path}: a topic applies to ROS bags, not {fmt} recordings", "topic")
    cls = spec.load("reader")
    reader = cls(Path(path), topic) if spec.takes_topic else cls(Path(path))
    assert isinstance(reader, Reader)
    return reader


def open_colours(path: Path, topic: str) -> Iterable[tuple[int, np.ndarray]]:
    """A bag's colour stream (``topic``) as ``(stamp ns, BGR or grey image)`` in time order."""
    fmt = detect_format(Path(path))
    if not FORMATS[fmt].takes_topic:
        raise InputError(f"{path}: a colour topic is read from a ROS bag, not a {fmt} recording")
    from d2sr.frames.rosbag import BagColours

    return BagColours(Path(path), topic)


def open_writer(
    path: Path, format: str, depth_scale: float, intrinsics: Intrinsics | None = None, **options: object
) -> Writer:
    """A writer; the output appears at ``path`` only when it is closed without error."""
    if format not in FORMATS:
        raise InputError(f"unknown format {format!r}; known: {', '.join(FORMATS)}")
    writer = FORMATS[format].load("writer")(Path(path), depth_scale, intrinsics, **options)
    assert isinstance(writer, Writer)
    return writer
