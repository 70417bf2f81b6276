"""The on-disk layout of the frame folders d2sr writes, in one place: a recording of a simulated room
(``d2sr simulate``: per sensor ``depth/``, ``clean/``, ``masks/``), a run (``d2sr run``: per sensor
``depth/``, ``masks/``, and ``confidence/`` with ``--fill``), repaired frames (``d2sr recover``:
``<name>.png`` and ``masks/``) and labels (``d2sr label``: ``depth/``, ``masks/`` and the frames labelled,
``interfered/``). Each stream is a PNG folder a reader opens again: 16-bit depth in the recording's scale,
masks as uint8 (255 = interfered), and a ``meta.json`` once finished."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Intrinsics, check_name
from d2sr.frames.png import encode_png, write_meta

__all__ = ["LABELS", "RECORDING", "REPAIRED", "RUN", "RUN_FILLED", "FrameFolder", "sensor_dir"]

#: stream -> its sub-folder ("" = the folder itself)
RECORDING = {"depth": "depth", "clean": "clean", "masks": "masks"}
RUN = {"depth": "depth", "masks": "masks"}
RUN_FILLED = {"depth": "depth", "masks": "masks", "confidence": "confidence"}  # d2sr run --fill
REPAIRED = {"depth": "", "masks": "masks"}
LABELS = {"depth": "depth", "masks": "masks", "interfered": "interfered"}  # the frames labelled, beside
MASK_STREAMS = ("masks",)


def sensor_dir(root: Path, sensor: int) -> Path:
    """Sensor ``sensor``'s part of a multi-sensor recording or run."""
    return Path(root) / f"sensor{sensor}"


class FrameFolder:
    """Named frames of several streams under ``root``; each file lands under a temporary name and is
    renamed, so a reader (or a resumed run) never sees half a PNG."""

    def __init__(self, root: Path, streams: dict[str, str], create: bool = True) -> None:
        """``create=False``: a folder only read (nothing is made on disk)."""
        self.root, self.streams = Path(root), streams
        self._written: set[str] = set()
        for sub in streams.values() if create else ():
            (self.root / sub).mkdir(parents=True, exist_ok=True)

    def path(self, stream: str, name: str) -> Path:
        return self.root / self.streams[stream] / f"{check_name(name, str(self.root))}.png"

    def has(self, name: str) -> bool:
        """Whether every stream holds frame ``name``."""
        return all(self.path(s, name).is_file() for s in self.streams)

    def write(self, name: str, **images: np.ndarray) -> None:
        """One frame of each stream given (boolean masks become 0/255); a name is written once."""
        if name in self._written:
            raise InputError(f"{self.root}: a second frame named {name[:60]!r}; frame names must be unique")
        self._written.add(name)
        for stream, img in images.items():
            if img.dtype == bool:
                img = img.astype(np.uint8) * 255
            target = self.path(stream, name)
            tmp = target.with_name(f".{name}.png.tmp")
            tmp.write_bytes(encode_png(img, name))
            os.replace(tmp, target)

    def finish(self, depth_scale: float, intrinsics: Intrinsics | None, rows: list[dict[str, Any]]) -> None:
        """Each stream's ``meta.json``: depth streams get the scale and ``rows`` (name, timestamp, extras),
        mask streams the names and timestamps."""
        for stream, sub in self.streams.items():
            if stream in MASK_STREAMS:
                keep: list[dict[str, Any]] = [
                    {k: r[k] for k in ("name", "timestamp_ns") if k in r} for r in rows
                ]
                write_meta(self.root / sub, 1.0, intrinsics, keep)
            else:
                write_meta(self.root / sub, depth_scale, intrinsics, rows)
