"""The one small protocol every depth format implements: a reader yields frames, a writer takes them.

Depth arrays stay in their stored units (``uint16`` counts of ``1/depth_scale`` metres, or ``float32``
metres with ``depth_scale == 1``) so that every format round-trips bit-exactly; ``to_metres`` converts.
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

import numpy as np

from d2sr.atomic import commit, discard, temp_for
from d2sr.errors import InputError

__all__ = [
    "PLAUSIBLE_M",
    "Frame",
    "Intrinsics",
    "Reader",
    "Writer",
    "check_depth",
    "check_plausible",
    "to_metres",
]


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a depth image (pixels)."""

    width: int
    height: int
    fx: float
    fy: float
    px: float
    py: float

    def scaled(self, width: int, height: int) -> Intrinsics:
        sx, sy = width / self.width, height / self.height
        return Intrinsics(width, height, self.fx * sx, self.fy * sy, self.px * sx, self.py * sy)

    def to_dict(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("width", "height", "fx", "fy", "px", "py")}

    @classmethod
    def from_dict(cls, d: dict) -> Intrinsics:
        try:
            return cls(int(d["width"]), int(d["height"]), *(float(d[k]) for k in ("fx", "fy", "px", "py")))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"intrinsics: missing or bad field {exc}") from None


@dataclass(frozen=True)
class Frame:
    """One depth image. ``name`` has no extension; outputs are written as ``<name>.png``."""

    name: str
    depth: np.ndarray
    timestamp_ns: int | None = None
    meta: dict = field(default_factory=dict, compare=False)


def check_depth(depth: np.ndarray, where: str) -> np.ndarray:
    """A depth image is 2-D, uint16 (counts) or float32 (metres), and finite."""
    if not isinstance(depth, np.ndarray):
        raise InputError(f"{where}: depth must be a numpy array, got {type(depth).__name__}")
    if depth.ndim != 2:
        shape = "x".join(map(str, depth.shape))
        raise InputError(f"{where}: depth must be a single-channel 2-D image, got shape {shape}")
    if depth.dtype == np.float32:
        if not np.isfinite(depth).all():
            raise InputError(f"{where}: depth has NaN or infinite values")
        if (depth < 0).any():
            raise InputError(f"{where}: depth has negative values")
    elif depth.dtype != np.uint16:
        raise InputError(f"{where}: depth must be uint16 or float32, got {depth.dtype}")
    return depth


def to_metres(depth: np.ndarray, depth_scale: float) -> np.ndarray:
    """float32 metres (0 = no return)."""
    return depth.astype(np.float32) / np.float32(depth_scale)


PLAUSIBLE_M = (0.1, 10.0)  # median depth of an indoor frame, metres


def check_plausible(name: str, metres: np.ndarray, scale: float) -> None:
    """A frame's median depth must be plausible indoors: a wrong --depth-scale shows there."""
    valid = metres[metres > 0]
    med = float(np.median(valid)) if valid.size else 0.0
    if valid.size and not PLAUSIBLE_M[0] <= med <= PLAUSIBLE_M[1]:
        raise InputError(
            f"frame {name}: median depth {med:.2f} m at --depth-scale {scale:g}; "
            "is the scale right? (units per metre: 1000 for mm, 4000 for raw L515)"
        )


def check_scale(depth_scale: float | None, where: str) -> float | None:
    if depth_scale is not None and not (np.isfinite(depth_scale) and depth_scale > 0):
        raise InputError(f"{where}: depth scale must be a positive number, got {depth_scale}")
    return depth_scale


_MS_STAMP = re.compile(r"(?:^|[_-])(\d{13})$")


def stamp_from_name(name: str) -> int | None:
    """RealSense tools name frames ``..._<ms since epoch>``; use that when no metadata says otherwise."""
    m = _MS_STAMP.search(name)
    return int(m.group(1)) * 1_000_000 if m else None


class Reader(ABC):
    """A recording opened for reading: metadata up front, frames in time order."""

    #: Units per metre of the stored depth (None: the recording does not say; the caller decides).
    depth_scale: float | None = None
    intrinsics: Intrinsics | None = None

    def __init__(self, path: Path) -> None:
        self.path = Path(path)

    @abstractmethod
    def __iter__(self) -> Iterator[Frame]: ...

    @abstractmethod
    def __len__(self) -> int: ...

    @property
    def shape(self) -> tuple[int, int] | None:
        """(height, width) when known without decoding every frame."""
        return None

    def close(self) -> None:  # noqa: B027 - most readers hold nothing open between frames
        """Release files; readers that hold none do nothing."""

    def __enter__(self) -> Reader:
        return self

    def __exit__(
        self, *exc: tuple[type[BaseException] | None, BaseException | None, TracebackType | None]
    ) -> None:
        self.close()


class Writer(ABC):
    """A recording opened for writing. Nothing appears at ``path`` until ``close`` succeeds; leaving the
    ``with`` block through an exception removes the partial output."""

    def __init__(self, path: Path, depth_scale: float, intrinsics: Intrinsics | None = None) -> None:
        self.path = Path(path)
        self.depth_scale = float(check_scale(depth_scale, str(path)) or 0)
        self.intrinsics = intrinsics
        self.count = 0
        self.shape: tuple[int, int] | None = None
        self._tmp = temp_for(self.path, is_dir=self.is_dir)

    #: Whether the output is a folder (PNG) or a single file (npz, bags).
    is_dir = False

    def write(self, frame: Frame) -> None:
        depth = check_depth(frame.depth, f"{self.path}: frame {frame.name}")
        if self.shape is None:
            self.shape = depth.shape  # type: ignore[assignment]
        elif depth.shape != self.shape:
            raise InputError(f"{self.path}: frame {frame.name} is {depth.shape}, earlier frames {self.shape}")
        self._write(frame)
        self.count += 1

    @abstractmethod
    def _write(self, frame: Frame) -> None: ...

    def _finish(self) -> None:  # noqa: B027 - formats with a trailer (index, metadata) write it here
        """Complete the temporary output before it is moved into place."""

    def close(self) -> None:
        """Finish and move the output into place."""
        if self._tmp is None:
            return
        try:
            self._finish()
        except BaseException:
            self.abort()
            raise
        commit(self._tmp, self.path)
        self._tmp = None

    def abort(self) -> None:
        """Remove the partial output."""
        if self._tmp is not None:
            discard(self._tmp)
            self._tmp = None

    def __enter__(self) -> Writer:
        return self

    def __exit__(
        self, etype: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if etype is None:
            self.close()
        else:
            self.abort()
