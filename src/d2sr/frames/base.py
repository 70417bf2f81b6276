"""The one small protocol every depth format implements: a reader yields frames, a writer takes them.

Depth arrays stay in their stored units (``uint16`` counts of ``1/depth_scale`` metres, or ``float32``
metres with ``depth_scale == 1``) so that every format round-trips bit-exactly; ``to_metres`` converts.
"""

from __future__ import annotations

import math
import numbers
import os
import re
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Protocol

import numpy as np

from d2sr.atomic import commit, discard, state, temp_for
from d2sr.errors import InputError
from d2sr.frames.encoded import MAX_PIXELS, check_pixels

__all__ = [
    "MAX_PIXELS",
    "PLAUSIBLE_M",
    "Frame",
    "Frames",
    "Intrinsics",
    "Reader",
    "Writer",
    "better_scale",
    "check_depth",
    "check_name",
    "check_names",
    "looks_like_intensity",
    "probe",
    "to_metres",
]


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a depth image (pixels): an image d2sr takes (``check_pixels``), focal lengths
    finite and positive, a finite principal point; anything else is one ``InputError`` when made."""

    width: int
    height: int
    fx: float
    fy: float
    px: float
    py: float

    def __post_init__(self) -> None:
        w, h = self.width, self.height
        if not all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in (w, h)):
            raise InputError(f"intrinsics: width and height must be whole numbers, got {w!r} x {h!r}"[:120])
        check_pixels(int(h), int(w), "intrinsics")
        if not (positive_finite(self.fx) and positive_finite(self.fy)):
            raise InputError(
                f"intrinsics: fx and fy must be finite and positive, got {self.fx!r}, {self.fy!r}"
            )
        if not (finite_real(self.px) and finite_real(self.py)):
            raise InputError(f"intrinsics: px and py must be finite, got {self.px!r}, {self.py!r}"[:120])

    def scaled(self, width: int, height: int) -> Intrinsics:
        sx, sy = width / self.width, height / self.height
        return Intrinsics(width, height, self.fx * sx, self.fy * sy, self.px * sx, self.py * sy)

    def to_dict(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("width", "height", "fx", "fy", "px", "py")}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Intrinsics:
        try:
            w, h, *k = int(d["width"]), int(d["height"]), *(float(d[k]) for k in ("fx", "fy", "px", "py"))
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise InputError(f"intrinsics: missing or bad field {str(exc)[:60]}") from None
        return cls(w, h, *k)


@dataclass(frozen=True)
class Frame:
    """One depth image. ``name`` has no extension; outputs are written as ``<name>.png``."""

    name: str
    depth: np.ndarray
    timestamp_ns: int | None = None
    meta: dict[str, Any] = field(default_factory=dict, compare=False)


def check_depth(depth: np.ndarray, where: str) -> np.ndarray:
    """A depth image is 2-D, uint16 (counts) or float32 (metres), and finite."""
    if not isinstance(depth, np.ndarray):
        raise InputError(f"{where}: depth must be a numpy array, got {type(depth).__name__}")
    if depth.ndim != 2:
        shape = "x".join(map(str, depth.shape))
        raise InputError(f"{where}: depth must be a single-channel 2-D image, got shape {shape}")
    check_pixels(depth.shape[0], depth.shape[1], where)
    if depth.dtype == np.float32:
        if not np.isfinite(depth).all():
            raise InputError(f"{where}: depth has NaN or infinite values")
        if (depth < 0).any():
            raise InputError(f"{where}: depth has negative values")
    elif depth.dtype != np.uint16:
        raise InputError(f"{where}: depth must be uint16 or float32, got {depth.dtype}")
    return depth


MAX_NAME = 200  # bytes in a frame's name: with its extension and a temporary prefix, under 255


def check_name(name: object, where: str) -> str:
    """A frame's name as a file name in an output folder: any characters or bytes, but not empty, not a
    path (no ``/``, ``\\`` or NUL, not ``.`` or ``..``) and not longer than ``MAX_NAME`` bytes."""
    if not isinstance(name, str) or not name or name in (".", ".."):
        raise InputError(f"{where}: a frame name must be a non-empty name, got {str(name)[:40]!r}")
    if any(c in name for c in "/\\\x00"):
        raise InputError(f"{where}: frame name {name[:60]!r} is a path, not a name")
    if len(os.fsencode(name)) > MAX_NAME:
        raise InputError(f"{where}: frame name {name[:40]!r}... is over {MAX_NAME} bytes")
    return name


def check_names(names: list[str], where: str) -> list[str]:
    """``check_name`` for each, and no name twice (a second frame of a name would replace the first)."""
    seen: set[str] = set()
    for n in names:
        check_name(n, where)
        if n in seen:
            raise InputError(f"{where}: two frames are named {n[:60]!r}; frame names must be unique")
        seen.add(n)
    return names


def to_metres(depth: np.ndarray, depth_scale: float) -> np.ndarray:
    """float32 metres (0 = no return). One pass and one new array: the cast happens inside the division
    (the same values as casting first)."""
    out: np.ndarray = np.divide(depth, np.float32(depth_scale), dtype=np.float32)
    return out


def to_units(metres: np.ndarray, depth_scale: float) -> np.ndarray:
    """uint16 depth units from metres: a return stays a return (at least one unit), 0 stays no return."""
    return np.where(metres > 0, np.clip(np.rint(metres * depth_scale), 1, 65535), 0).astype(np.uint16)


PLAUSIBLE_M = (0.1, 10.0)  # median depth of an indoor frame, metres (the upper end: max_range)
#: Units per metre depth sensors store, and what they are called.
KNOWN_SCALES = {
    1000.0: "millimetres",
    4000.0: "raw L515, 0.25 mm",
    5000.0: "TUM, 0.2 mm",
    10000.0: "0.1 mm",
}
TYPICAL_M = 2.5  # median depth of a typical indoor frame, metres
#: Peak working memory per pixel of a frame repaired (two frames in flight, two passes of the model, the
#: repair around it): d2sr recover --repair all on 4096x4096 frames peaked at 4.7 GB resident (2 cores).
WORK_BYTES = 280
MARGIN = 2.5  # how much closer to typical another scale must bring the median before we say so
INTENSITY_GRADIENT = 0.02  # median relative step between neighbours: depth < 0.002, IR images ~ 0.05
TRAINED_PIXELS = (
    64 * 64,
    1280 * 960,
)  # frame sizes far outside these are far from the models' training (640x480)


def _median_m(depth: np.ndarray, scale: float) -> float | None:
    m = to_metres(depth, 1.0 if depth.dtype == np.float32 else scale)
    valid = m[m > 0]
    return float(np.median(valid)) if valid.size >= max(1, depth.size // 1000) else None


def better_scale(med: float, scale: float) -> float | None:
    """A known sensor scale under which the median depth ``med`` (metres at ``scale``) is much more like an
    indoor scene (log distance to TYPICAL_M by a factor of MARGIN or more), or None."""

    def off(m: float) -> float:
        return float(abs(np.log(m / TYPICAL_M)))

    best = min((s for s in KNOWN_SCALES if s != scale), key=lambda s: off(med * scale / s))
    return best if off(med) - off(med * scale / best) >= np.log(MARGIN) else None


def _scales_hint(med: float, scale: float) -> str:
    """Every known sensor scale (in ``KNOWN_SCALES``' order) under which the median depth ``med`` (metres at
    ``scale``) would read like an indoor scene (within a factor ``MARGIN`` of ``TYPICAL_M``): the user knows
    which one is their sensor's."""
    near = [
        s for s in KNOWN_SCALES if s != scale and abs(np.log(med * scale / s / TYPICAL_M)) <= np.log(MARGIN)
    ]
    if not near:
        return "units per metre: 1000 for mm, 4000 for raw L515"
    return "; ".join(f"at {s:g} ({KNOWN_SCALES[s]}) it would be {med * scale / s:.2f} m" for s in near)


def looks_like_intensity(depth: np.ndarray) -> bool:
    """Depth is piecewise smooth (neighbours within a fraction of a percent); an infrared or amplitude
    image is textured (neighbours several percent apart)."""
    a = depth.astype(np.float32)
    left, right = a[:, :-1], a[:, 1:]
    ok = (left > 0) & (right > 0)
    if ok.sum() < 100:
        return False
    step = np.abs(right[ok] - left[ok]) / np.maximum(right[ok], left[ok])
    return float(np.median(step)) > INTENSITY_GRADIENT


def probe(frames: list[Frame], scale: float, max_range: float = PLAUSIBLE_M[1]) -> list[str]:
    """Check frames sampled through a recording before it is processed: values, size, and a depth scale
    that makes indoor sense over all of them (an InputError when far off). Returns warnings (one line
    each) for what may be a mistake: a scale that fits another sensor better, frames with no valid depth,
    frames that look like an intensity image, sizes far from the models' training."""
    warnings, meds, empty, textured = [], [], [], []
    for f in frames:
        check_depth(f.depth, f"frame {f.name}")  # its size too (``check_pixels``)
        med = _median_m(f.depth, scale)
        if med is None:
            empty.append(f.name)
            continue
        meds.append(med)
        if looks_like_intensity(f.depth):
            textured.append(f.name)
    if meds:
        med = float(np.median(meds))
        if not PLAUSIBLE_M[0] <= med <= max_range:
            raise InputError(
                f"median depth {med:.2f} m at depth scale {scale:g} over {len(meds)} sampled frames; is the "
                f"scale right? ({_scales_hint(med, scale)}; a scene beyond {max_range:g} m needs a larger "
                "max_range)",
                "depth_scale",
            )
        uint16 = any(f.depth.dtype == np.uint16 for f in frames)
        if uint16 and better_scale(med, scale) is not None:
            warnings.append(f"median depth {med:.2f} m at depth scale {scale:g}; {_scales_hint(med, scale)}: "
                            "give that depth scale if it is your sensor's unit")  # fmt: skip
    if empty:
        warnings.append(f"{len(empty)} of {len(frames)} sampled frames have no valid depth (e.g. {empty[0]})")
    if textured:
        warnings.append(
            f"{len(textured)} of {len(frames)} sampled frames look like an intensity (IR) image, not depth "
            f"(e.g. {textured[0]}); is this the depth stream?"
        )
    if frames:
        h, w = frames[0].depth.shape
        if not TRAINED_PIXELS[0] <= h * w <= TRAINED_PIXELS[1]:
            mb = h * w * WORK_BYTES / 2**20
            warnings.append(
                f"frames are {w}x{h}; the models were trained on 640x480 frames and their crops "
                f"(results may be poor; about {mb:.0f} MB of working memory)"
            )
    return warnings


def finite_real(x: object) -> bool:
    """``x`` is a real number and finite (not a bool, a string, or an integer too large for a float)."""
    if not isinstance(x, numbers.Real) or isinstance(x, bool):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:  # an int beyond a float's range
        return False


def positive_finite(x: object) -> bool:
    """``x`` is a real number, finite and positive: what a scale read from a file must be before any
    arithmetic on it."""
    return finite_real(x) and float(x) > 0  # type: ignore[arg-type]  # a Real, checked


def check_scale(depth_scale: float | None, where: str) -> float | None:
    """A depth scale read from a recording: None, or a positive finite number (anything else is refused
    in one line, not a numpy error)."""
    if depth_scale is not None and not positive_finite(depth_scale):
        raise InputError(f"{where}: depth scale must be a positive number, got {str(depth_scale)[:40]}")
    return depth_scale


_MS_STAMP = re.compile(r"(?:^|[_-])(\d{13})$")


def stamp_from_name(name: str) -> int | None:
    """RealSense tools name frames ``..._<ms since epoch>``; use that when no metadata says otherwise."""
    m = _MS_STAMP.search(name)
    return int(m.group(1)) * 1_000_000 if m else None


class Frames(Protocol):
    """Frames in time order whose number is known up front: a ``Reader``, or a wrapper around one."""

    def __iter__(self) -> Iterator[Frame]: ...

    def __len__(self) -> int: ...


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

    def sample(self, k: int) -> list[Frame]:
        """Up to ``k`` frames spread through the recording (a stream that cannot seek: its first ``k``)."""
        got: list[Frame] = []
        for f in self:
            got.append(f)
            if len(got) >= k:
                break
        return got

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
        self._names: set[str] = set()
        self._tmp: Path | None = temp_for(self.path, is_dir=self.is_dir)
        self._before = state(self.path)  # what is there as the run begins: nothing else is replaced

    #: Whether the output is a folder (PNG) or a single file (npz, bags).
    is_dir = False

    def write(self, frame: Frame) -> None:
        check_name(frame.name, str(self.path))
        if frame.name in self._names:
            raise InputError(
                f"{self.path}: a second frame named {frame.name[:60]!r}; frame names must be unique"
            )
        depth = check_depth(frame.depth, f"{self.path}: frame {frame.name}")
        if self.shape is None:
            self.shape = depth.shape
        elif depth.shape != self.shape:
            raise InputError(f"{self.path}: frame {frame.name} is {depth.shape}, earlier frames {self.shape}")
        self._write(frame)
        self._names.add(frame.name)
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
        commit(self._tmp, self.path, self._before)
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


def crop_around(where: np.ndarray, margin: int) -> tuple[slice, slice] | None:
    """The rows and columns of a 2-D bool array's True pixels, widened by ``margin`` (cut at the image's
    top and left; slicing cuts the rest): the crop a filter of that reach needs. None when none is True."""
    rows, cols = np.flatnonzero(where.any(1)), np.flatnonzero(where.any(0))
    if rows.size == 0:
        return None
    return (
        slice(max(rows[0] - margin, 0), rows[-1] + margin + 1),
        slice(max(cols[0] - margin, 0), cols[-1] + margin + 1),
    )
