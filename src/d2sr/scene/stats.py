"""Per-pixel statistics of a still sensor's clean frames (numpy only): how often each pixel returns and the
spread of its returned depths. ``d2sr label`` judges a recording against them, and a scene reference keeps
them online (``d2sr.scene.reference``). Exact medians and quantiles in bounded memory: a long sequence is
read once per stripe of rows."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import positive_finite

__all__ = [
    "STAT_FIELDS",
    "CleanStats",
    "blur_shares",
    "clean_stats",
    "count_from",
    "sort_frames",
    "stack_stats",
]


@dataclass
class CleanStats:
    """Per-pixel statistics of a clean static sequence (depths in metres, float32)."""

    median: np.ndarray  # median over all frames, zeros included (the paper's reference frame)
    nz_median: np.ndarray  # median of returned depths (0 where never returned)
    lo: np.ndarray  # 2nd percentile of returned depths
    hi: np.ndarray  # 98th percentile of returned depths
    rate: np.ndarray  # share of frames with a return
    mean_err: np.ndarray  # mean |frame - median| (the paper's random-error statistic)
    frames: int

    @property
    def shape(self) -> tuple[int, int]:
        return self.median.shape


def clean_stats(
    frames: Callable[[], Iterable[np.ndarray]],
    depth_scale: float,
    memory_mb: float = 64.0,
    progress: Callable[[float], None] | None = None,
    count: int | None = None,
) -> CleanStats:
    """Statistics of a clean sequence. ``frames`` returns a fresh iterator over the uint16 frames each time
    it is called: the sequence is read once per stripe of rows that fits in ``memory_mb``. Pass ``count``
    when the reader knows it, to skip the pass that counts frames."""
    if depth_scale <= 0 or not np.isfinite(depth_scale):
        raise InputError(f"depth scale must be a positive number, got {depth_scale}")
    if not positive_finite(memory_mb):  # NaN read the whole sequence at once
        raise ConfigError(f"memory_mb must be a positive number, got {memory_mb}")
    first = iter(frames())
    f0 = next(first, None)
    if f0 is None:
        raise InputError("the clean sequence is empty")
    n = count if count is not None else 1 + sum(1 for _ in first)
    if n < 3:
        raise InputError(f"the clean sequence needs at least 3 frames, got {n}")
    h, w = f0.shape
    rows = int(max(1, min(h, memory_mb * 2**20 // (n * w * 2 * 2))))  # the stripe and its sorted copy
    out = {k: np.zeros((h, w), np.float32) for k in ("median", "nz_median", "lo", "hi", "rate", "mean_err")}
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        stack = np.empty((n, r1 - r0, w), np.uint16)
        seen = 0
        for i, f in enumerate(frames()):
            if f.shape != (h, w):
                raise InputError(f"clean frame {i} is {f.shape[1]}x{f.shape[0]}, the first is {w}x{h}")
            if i >= n:
                break
            stack[i] = f[r0:r1]
            seen = i + 1
        if seen != n:
            raise InputError(f"the clean sequence changed while being read ({seen} frames, expected {n})")
        for name, v in stack_stats(stack).items():
            out[name][r0:r1] = v
        if progress:
            progress(r1 / h)
    scaled = {k: v / np.float32(depth_scale) if k != "rate" else v for k, v in out.items()}
    return CleanStats(frames=n, **scaled)


#: ``CleanStats``' per-pixel fields, as ``stack_stats`` computes them.
STAT_FIELDS = ("median", "rate", "nz_median", "lo", "hi", "mean_err")


def stack_stats(
    stack: np.ndarray, fields: tuple[str, ...] = STAT_FIELDS, part: float = 0.25
) -> dict[str, np.ndarray]:
    """``CleanStats``' fields (in the frames' units, ``rate`` a share) of a stack of uint16 frames or of
    rows of them, ``(n, rows, width)``; only ``fields`` (a scene reference refreshes the ones it reads).
    Also ``gap`` when asked: the widest gap between a pixel's sorted returns that leaves at least ``part``
    of them on each side (0 where none does), which two depths at one pixel open and one depth's noise
    does not."""
    n = stack.shape[0]
    srt = sort_frames(stack)
    k = (srt > 0).sum(axis=0)  # returns per pixel; zeros sort first
    out: dict[str, np.ndarray] = {}
    if "gap" in fields:
        out["gap"] = _gap(srt, k, part)
    if "median" in fields or "mean_err" in fields:
        out["median"] = _middle(srt)
    if "rate" in fields:
        out["rate"] = (k / n).astype(np.float32)
    for name, q in (("nz_median", 0.5), ("lo", 0.02), ("hi", 0.98)):
        if name in fields:
            out[name] = _at_returns(srt, k, q)
    if "mean_err" in fields:
        out["mean_err"] = np.abs(stack.astype(np.float32) - out["median"][None]).mean(axis=0)
    return {name: out[name] for name in fields}


def _gap(srt: np.ndarray, k: np.ndarray, part: float) -> np.ndarray:
    """``stack_stats``' ``gap`` (float32, in the frames' units) of a sorted stack, ``k`` returns a pixel."""
    n = srt.shape[0]
    if n < 2:
        return np.zeros(k.shape, np.float32)
    counts = np.arange(n + 1)
    least = np.maximum(np.ceil(part * counts), 1).astype(np.intp)  # returns each side keeps, per count
    # The gap after sorted index i leaves i + 1 - (n - k) returns below it and n - 1 - i above: which gaps
    # count depends on k alone, so it is looked up per count (a per-pixel float ceil costs 20x the gather).
    at = np.arange(n - 1, dtype=np.intp)[:, None]
    counted = (at >= n - counts + least - 1) & (at <= n - 1 - least)  # (gap, count)
    gaps = np.diff(srt, axis=0)  # sorted: never negative
    gaps *= counted[:, k]
    out: np.ndarray = gaps.max(axis=0).astype(np.float32)
    return out


def sort_frames(stack: np.ndarray) -> np.ndarray:
    """``np.sort(stack, axis=0)`` for a few frames (up to 32): compare-and-swap whole frames through Batcher's
    network, faster than sorting each pixel's short column, which numpy does one column at a time."""
    n = stack.shape[0]
    if n > 32:
        return np.sort(stack, axis=0)
    rows = [np.array(f) for f in stack]
    for a, b in _network(n):
        low = np.minimum(rows[a], rows[b])
        np.maximum(rows[a], rows[b], out=rows[b])
        rows[a] = low
    return np.stack(rows) if rows else np.array(stack)


@lru_cache
def _network(n: int) -> tuple[tuple[int, int], ...]:
    """Batcher's odd-even merge sort: the compare-and-swap pairs that sort ``n`` values (any ``n``)."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return tuple(pairs)


def _at_returns(srt: np.ndarray, k: np.ndarray, q: float) -> np.ndarray:
    """``_at`` the ``q`` quantile of each pixel's ``k`` returns (the last ``k`` of its sorted values),
    float32; 0 where none. The index and weight depend on ``k`` alone: looked up per count, then one gather
    each from the flat stack (``take``, in place: a third less time than fancy indexing)."""
    n, size = srt.shape[0], k.size
    counts = np.arange(n + 1)
    pos = (n - counts) + q * np.maximum(counts - 1, 0)
    lo = np.minimum(np.floor(pos).astype(np.intp), n - 1)
    hi = np.minimum(lo + 1, n - 1)
    f = (pos - lo).astype(np.float32)
    flat, kk = srt.reshape(-1), k.reshape(-1)
    i = (lo * size).take(kk)
    i += np.arange(size, dtype=np.intp)
    a = flat.take(i).astype(np.float32)
    i += ((hi - lo) * size).take(kk)
    b = flat.take(i).astype(np.float32)
    b -= a
    b *= f.take(kk)
    a += b
    a[kk == 0] = 0
    out: np.ndarray = a.reshape(k.shape)
    return out


def _middle(srt: np.ndarray) -> np.ndarray:
    """Each pixel's median over a sorted stack, zeros included: one index for every pixel, so whole frames
    are read rather than gathered per pixel (float32, interpolated as ``np.quantile``'s linear method)."""
    pos = (srt.shape[0] - 1) / 2
    lo = int(np.floor(pos))
    hi = min(lo + 1, srt.shape[0] - 1)
    a = srt[lo].astype(np.float32)
    out: np.ndarray = a + np.float32(pos - lo) * (srt[hi].astype(np.float32) - a)
    return out


@lru_cache
def blur_shares(side: int) -> np.ndarray:
    """What ``cv2.blur`` gives a pixel of a 0/1 float32 image whose ``side`` x ``side`` window holds each
    count of ones (index 0 to side squared): an integer count then stands for the float share exactly."""
    out = np.zeros(side * side + 1, np.float32)
    for c in range(side * side + 1):
        window = np.zeros((side, side), np.float32)
        window.flat[:c] = 1
        out[c] = cv2.blur(window, (side, side))[side // 2, side // 2]
    return out


@lru_cache
def count_from(share: float, side: int) -> int:
    """The least count of ones in a ``side`` x ``side`` window whose ``cv2.blur`` share reaches ``share``
    (side squared + 1: none does)."""
    reach = np.flatnonzero(blur_shares(side) >= share)
    return int(reach[0]) if reach.size else side * side + 1
