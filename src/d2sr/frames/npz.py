"""One ``.npz`` file per recording: ``depth`` (frames, height, width), ``names``, ``timestamps_ns``
(-1 = unknown), ``depth_scale`` and optional ``intrinsics`` (JSON text)."""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics, Reader, Writer, check_depth, check_names, check_scale
from d2sr.frames.encoded import check_pixels

__all__ = ["NpzReader", "NpzWriter"]


class NpzReader(Reader):
    def __init__(self, path: Path) -> None:
        super().__init__(path)
        try:
            _check_header(self.path)
            with np.load(self.path, allow_pickle=False) as z:
                if "depth" not in z.files:
                    raise InputError(
                        f"{self.path}: npz has no 'depth' array (has: {', '.join(z.files) or 'none'})"
                    )
                self.depth = z["depth"]
                n = len(self.depth)
                self.names = (
                    [str(s) for s in z["names"]] if "names" in z.files else [f"{i:06d}" for i in range(n)]
                )
                self.stamps = z["timestamps_ns"] if "timestamps_ns" in z.files else np.full(n, -1)
                scale = float(z["depth_scale"]) if "depth_scale" in z.files else None
                intr = json.loads(str(z["intrinsics"])) if "intrinsics" in z.files else None
        except InputError:
            raise
        except (
            OSError,
            ValueError,
            TypeError,
            IndexError,
            zipfile.BadZipFile,
            EOFError,
            RecursionError,
            SyntaxError,  # a header numpy cannot parse (a number of 5,000 digits)
            MemoryError,
        ) as exc:
            raise InputError(f"{self.path}: corrupt or truncated npz: {exc}") from None
        if self.depth.ndim == 2:
            self.depth = self.depth[None]
        if self.depth.ndim != 3 or len(self.depth) == 0:
            raise InputError(f"{self.path}: 'depth' must be (frames, height, width), got {self.depth.shape}")
        check_depth(self.depth[0], str(self.path))
        if len(self.names) != len(self.depth) or len(self.stamps) != len(self.depth):
            raise InputError(f"{self.path}: names/timestamps_ns do not match the number of frames")
        check_names(self.names, str(self.path))
        if self.stamps.dtype.kind not in "iu":
            raise InputError(f"{self.path}: timestamps_ns must be whole numbers, got {self.stamps.dtype}")
        self.depth_scale = check_scale(scale, str(self.path))
        self.intrinsics = Intrinsics.from_dict(intr) if intr else None

    def __len__(self) -> int:
        return len(self.depth)

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.depth.shape[1]), int(self.depth.shape[2])

    def __iter__(self) -> Iterator[Frame]:
        for i in range(len(self.depth)):
            yield self._frame(i)

    def _frame(self, i: int) -> Frame:
        s = int(self.stamps[i])
        return Frame(
            self.names[i], check_depth(self.depth[i], f"{self.path}: frame {i}"), None if s < 0 else s
        )

    def sample(self, k: int) -> list[Frame]:
        return [self._frame(int(i)) for i in np.unique(np.linspace(0, len(self) - 1, k).round())]


NAME_BYTES = 4 * 4096  # a frame's name: at most 4096 characters (numpy stores 4 bytes each)
INTRINSICS_BYTES = 1 << 16  # the intrinsics' JSON text


def _header(z: zipfile.ZipFile, member: str) -> tuple[tuple[int, ...], np.dtype[Any]]:
    with z.open(member) as fh:
        version = np.lib.format.read_magic(fh)
        read = (
            np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        )
        shape, _, dtype = read(fh)
    return tuple(shape), np.dtype(dtype)


def _check_header(path: Path) -> None:
    """Each member the reader reads, from its header before it is read (an npz is read whole): ``depth``'s
    frames within the pixel budget, all of them within half this machine's memory; ``names``,
    ``timestamps_ns``, ``depth_scale`` and ``intrinsics`` no larger than the frames they describe need (a
    390 kB file's names took 758 MB); and no member unpacking to more than its header says."""
    with zipfile.ZipFile(path) as z:
        members = {i.filename: i for i in z.infolist()}
        if "depth.npy" not in members:
            return  # the reader says what is missing
        shapes = {}
        for name in ("depth", "names", "timestamps_ns", "depth_scale", "intrinsics"):
            info = members.get(f"{name}.npy")
            if info is None:
                continue
            shape, dtype = _header(z, info.filename)
            size = int(np.prod(shape, dtype=np.float64)) * dtype.itemsize
            if info.file_size > size + 65536:  # the header is at most a few kB
                raise InputError(f"{path}: '{name}' unpacks to more than its header says")
            shapes[name] = (shape, dtype, size)
    shape, dtype, total = shapes["depth"]
    frames = shape[0] if len(shape) == 3 else 1
    limits = {
        "names": (frames * NAME_BYTES, "its frames' names"),
        "timestamps_ns": (frames * 8, "a stamp per frame"),
        "depth_scale": (8, "one number"),
        "intrinsics": (INTRINSICS_BYTES, "a camera's intrinsics"),
    }
    for name, (most, what) in limits.items():
        if name in shapes and shapes[name][2] > most:
            raise InputError(f"{path}: '{name}' declares {shapes[name][2]:,} bytes, more than {what} need")
    if len(shape) in (2, 3) and all(isinstance(n, int) for n in shape):
        h, w = shape[-2:]
        check_pixels(h, w, f"{path}: 'depth'")
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        if total > memory // 2:
            raise InputError(
                f"{path}: 'depth' holds {total / 2**30:.1f} GiB, over half this machine's memory (an npz is "
                "read whole); write it as a PNG folder or a bag"
            )


class NpzWriter(Writer):
    """Frames are collected in memory and saved (compressed) on close: npz cannot be appended to."""

    def __init__(self, path: Path, depth_scale: float, intrinsics: Intrinsics | None = None) -> None:
        super().__init__(path, depth_scale, intrinsics)
        self._frames: list[Frame] = []

    def _write(self, frame: Frame) -> None:
        if self._frames and frame.depth.dtype != self._frames[0].depth.dtype:
            raise InputError(f"{self.path}: frame {frame.name} is {frame.depth.dtype}, earlier frames differ")
        self._frames.append(frame)

    def _finish(self) -> None:
        if not self._frames:
            raise InputError(f"{self.path}: no frames to write")
        arrays: dict[str, Any] = {
            "depth": np.stack([f.depth for f in self._frames]),
            "names": np.array([f.name for f in self._frames]),
            "timestamps_ns": np.array(
                [-1 if f.timestamp_ns is None else f.timestamp_ns for f in self._frames]
            ),
            "depth_scale": np.array(self.depth_scale),
        }
        if self.intrinsics is not None:
            arrays["intrinsics"] = np.array(json.dumps(self.intrinsics.to_dict()))
        assert self._tmp is not None
        with self._tmp.open("wb") as fh:
            np.savez_compressed(fh, **arrays)
