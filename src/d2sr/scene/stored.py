"""A still sensor's scene learned once from a clean recording and stored in one file (``d2sr scene learn``):
its owner records the room before the other sensors start and uses that scene for days.

The file is a numpy ``.npz`` read with ``allow_pickle=False`` (it holds arrays and one JSON text, never code):
the per-pixel statistics a scene reference keeps (``CleanStats``), and what they are of: the frames' shape,
the depth scale, how many clean frames, how far the scene trusts its pixels, and where it came from.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.atomic import atomic_file
from d2sr.errors import InputError
from d2sr.frames.base import positive_finite
from d2sr.frames.encoded import MAX_PIXELS
from d2sr.scene.stats import CleanStats, clean_stats

__all__ = ["FORMAT", "StoredScene", "learn_scene"]

FORMAT = "d2sr scene 1"  # what the file says it is
_ARRAYS = ("median", "nz_median", "lo", "hi", "rate", "mean_err")
_MAX_SIDE = 8192


@dataclass(frozen=True)
class StoredScene:
    """A scene learned from ``frames`` clean frames of ``source`` at ``depth_scale`` units per metre."""

    stats: CleanStats
    depth_scale: float
    frames: int
    source: str

    @property
    def shape(self) -> tuple[int, int]:
        return self.stats.shape

    def trusted(self, rate: float = 0.9) -> float:
        """The share of pixels the scene saw return in ``rate`` of its frames (with few frames, few)."""
        return float(np.mean(self.stats.rate >= rate))

    def check_fits(self, shape: tuple[int, ...], depth_scale: float, name: object) -> None:
        """One line (an ``InputError`` naming ``name``, the file) unless frames of ``shape`` at
        ``depth_scale`` units per metre are this scene's."""
        if self.shape != shape:
            raise InputError(
                f"{name}: a scene of {self.shape[1]}x{self.shape[0]} frames; these frames are "
                f"{shape[1]}x{shape[0]}", "scene_from"
            )  # fmt: skip
        if abs(self.depth_scale - depth_scale) > 1e-6 * depth_scale:
            raise InputError(
                f"{name}: a scene at depth scale {self.depth_scale:g}; these frames are at {depth_scale:g}",
                "scene_from",
            )

    def save(self, path: Path) -> None:
        """Write the file atomically (``path`` should end in ``.npz``)."""
        meta = {
            "format": FORMAT,
            "depth_scale": self.depth_scale,
            "frames": self.frames,
            "shape": list(self.shape),
            "source": self.source,
            "trusted": round(self.trusted(), 4),
        }
        arrays: dict[str, Any] = {k: getattr(self.stats, k).astype(np.float32) for k in _ARRAYS}
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
        # Stored as is: a 640x480 scene loads in about 12 ms where compressed it took 45 (7 MB against 4).
        with atomic_file(Path(path)) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    @classmethod
    def load(cls, path: Path) -> StoredScene:
        """Read a stored scene, or one line saying why the file is not one."""
        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such scene file", "scene_from")
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = _meta(path, _member(z, "meta", 1 << 16))
                h, w = meta["shape"]
                # each array is read only once its stored size says it is the scene's: a file cannot make
                # the reader unpack more than the scene it describes
                got = {k: _member(z, k, 4 * h * w) for k in _ARRAYS}
        except InputError:  # the description's own reason (an InputError is a ValueError too)
            raise
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
            why = type(exc).__name__
            raise InputError(f"{path}: not a scene file d2sr wrote ({why})", "scene_from") from None
        for k in _ARRAYS:
            a = got.get(k)
            if a is None or a.dtype != np.float32 or a.shape != (h, w) or not np.isfinite(a).all():
                raise InputError(f"{path}: its {k} is not a {w}x{h} float32 array", "scene_from")
        stats = CleanStats(frames=meta["frames"], **{k: np.array(got[k]) for k in _ARRAYS})
        _sensible(path, stats)
        return cls(stats, float(meta["depth_scale"]), int(meta["frames"]), str(meta["source"]))


def _member(z: Any, name: str, most: int) -> np.ndarray | None:
    """Array ``name`` of the open npz ``z``, None when absent or larger than ``most`` bytes unpacked (its
    header aside)."""
    if name not in z.files or z.zip.getinfo(f"{name}.npy").file_size > most + 4096:
        return None
    out: np.ndarray = z[name]
    return out


MAX_FRAMES = 10**9  # clean frames a scene is learned from: years of a camera's frames


def _sensible(path: Path, s: CleanStats) -> None:
    """Statistics a clean sequence can have: shares in 0..1, depths not negative, and where a pixel
    returned, its 2nd percentile at most its median, its median at most its 98th (a few micrometres of
    float32 aside)."""
    seen = s.rate > 0
    slack = np.float32(1e-4)
    ok = (
        bool(((s.rate >= 0) & (s.rate <= 1)).all())
        and all(bool((getattr(s, k) >= 0).all()) for k in ("median", "nz_median", "lo", "hi", "mean_err"))
        and bool((s.lo[seen] <= s.nz_median[seen] + slack).all())
        and bool((s.nz_median[seen] <= s.hi[seen] + slack).all())
    )
    if not ok:
        raise InputError(f"{path}: its statistics are none a clean sequence has", "scene_from")


def _meta(path: Path, raw: np.ndarray | None) -> dict[str, Any]:
    bad = InputError(f"{path}: not a scene file d2sr wrote (no description of it)", "scene_from")
    if raw is None or raw.dtype != np.uint8 or raw.ndim != 1 or raw.size > 1 << 16:
        raise bad
    try:
        meta = json.loads(raw.tobytes().decode())
    except (UnicodeDecodeError, ValueError):
        raise bad from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise bad
    shape, scale, frames = meta.get("shape"), meta.get("depth_scale"), meta.get("frames")
    ok = (
        isinstance(shape, list)
        and len(shape) == 2
        and all(isinstance(v, int) and 0 < v <= _MAX_SIDE for v in shape)
        and shape[0] * shape[1] <= MAX_PIXELS  # the frames d2sr takes: no larger scene is unpacked
        and positive_finite(scale)
        and isinstance(frames, int)
        and 1 <= frames <= MAX_FRAMES
        and isinstance(meta.get("source"), str)
    )
    if not ok:
        raise InputError(f"{path}: its description has the wrong types", "scene_from")
    return meta


def learn_scene(
    frames: Callable[[], Iterable[np.ndarray]], depth_scale: float, source: str, count: int | None = None
) -> StoredScene:
    """A scene from clean frames (``frames`` returns a fresh iterator over uint16 frames each time it is
    called; at least 3 frames)."""
    stats = clean_stats(frames, depth_scale, count=count)
    return StoredScene(stats, float(depth_scale), stats.frames, source)
