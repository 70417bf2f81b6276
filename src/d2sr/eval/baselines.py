"""Classical repairs of masked depth pixels (numpy/OpenCV), the baselines the recovery UNets must beat.

Each takes float32 metres (0 = no return) and a boolean mask of pixels to replace, and changes only those
pixels, filling them from the valid pixels outside the mask. ``identity`` changes nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

__all__ = ["BASELINES", "identity", "ip_basic", "last_clean", "median_fill", "nearest_fill", "telea"]


def identity(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return depth.copy()


def _sources(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return (depth > 0) & ~mask


def nearest_fill(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Each masked pixel takes the value of the nearest valid unmasked pixel."""
    src = _sources(depth, mask)
    if not src.any():
        return np.where(mask, 0, depth).astype(np.float32)
    _, labels = cv2.distanceTransformWithLabels(
        (~src).astype(np.uint8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL
    )
    values = np.zeros(int(labels.max()) + 1, np.float32)
    values[labels[src]] = depth[src]
    return np.where(mask, values[labels], depth).astype(np.float32)


def median_fill(depth: np.ndarray, mask: np.ndarray, size: int = 7, passes: int = 6) -> np.ndarray:
    """Masked pixels take the median of the valid pixels in a ``size`` window; repeated so larger holes
    fill from their rim inwards; what is still empty after that takes the nearest value."""
    r = size // 2
    out = np.where(mask, np.nan, np.where(depth > 0, depth, np.nan)).astype(np.float32)
    todo = mask.copy()
    for _ in range(passes):
        if not todo.any():
            break
        pad = np.pad(out, r, constant_values=np.nan)
        ys, xs = np.nonzero(todo)
        win = np.stack([pad[ys + dy, xs + dx] for dy in range(size) for dx in range(size)])
        ok = np.isfinite(win).any(axis=0)  # windows with no valid pixel wait for a later pass
        out[ys[ok], xs[ok]] = np.nanmedian(win[:, ok], axis=0)
        todo[ys[ok], xs[ok]] = False
    filled = np.where(np.isfinite(out), out, 0).astype(np.float32)
    if todo.any():
        filled = nearest_fill(filled, todo)
    return np.where(mask, filled, depth).astype(np.float32)


_DIAMOND = np.array(
    [[0, 0, 1, 0, 0], [0, 1, 1, 1, 0], [1, 1, 1, 1, 1], [0, 1, 1, 1, 0], [0, 0, 1, 0, 0]], np.uint8
)


def ip_basic(depth: np.ndarray, mask: np.ndarray, max_depth: float = 10.0) -> np.ndarray:
    """IP-Basic's fast fill (Ku et al., 2018), as published: invert depth so near wins, dilate with a
    diamond, close, fill small then large holes by dilation, median and Gaussian smoothing; only the
    masked pixels take the result."""
    d: np.ndarray = np.where(_sources(depth, mask), depth, 0).astype(np.float32)
    valid = d > 0.1
    d[valid] = max_depth - d[valid]
    d = cv2.dilate(d, _DIAMOND)
    d = cv2.morphologyEx(d, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    empty = d < 0.1
    d[empty] = cv2.dilate(d, np.ones((7, 7), np.uint8))[empty]
    empty = d < 0.1
    d[empty] = cv2.dilate(d, np.ones((31, 31), np.uint8))[empty]
    blurred = cv2.medianBlur(d, 5)
    valid = d > 0.1
    d[valid] = blurred[valid]
    blurred = cv2.GaussianBlur(d, (5, 5), 0)
    d[valid] = blurred[valid]
    out = np.where(d > 0.1, max_depth - d, 0).astype(np.float32)
    hole = mask & (out == 0)  # wider than its largest kernel: IP-Basic extends; we take the nearest value
    if hole.any():
        out = nearest_fill(out, hole)
    return np.where(mask, out, depth).astype(np.float32)


def telea(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """OpenCV inpainting (Telea) of the masked pixels. Pixels without a return outside the mask first take
    their nearest valid value, so that inpainting draws on surfaces, not on zeros."""
    src = _sources(depth, mask)
    dense = nearest_fill(np.where(src, depth, 0).astype(np.float32), ~src)
    # In millimetres as uint16: OpenCV's Telea on float32 images gives wrong values (OpenCV 5.0).
    mm = np.clip(np.rint(dense * 1000), 0, 65535).astype(np.uint16)
    out = cv2.inpaint(mm, mask.astype(np.uint8), 5, cv2.INPAINT_TELEA).astype(np.float32) / 1000
    return np.where(mask, out, depth).astype(np.float32)


def last_clean(depth: np.ndarray, mask: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """The temporal baseline: masked pixels take the last clean frame's value where it had a return, and
    inpainting (``telea``) elsewhere. Right for a still sensor, stale for a moving one."""
    out = telea(depth, mask)
    take = mask & (previous > 0)
    out[take] = previous[take]
    return out


BASELINES: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "median": median_fill,
    "nearest": nearest_fill,
    "ip-basic": ip_basic,
    "inpaint": telea,
}
