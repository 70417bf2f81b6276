"""The repair: how a recovery model's prediction becomes a repaired frame, without harm (``guard``), over
one or more passes (``recover_passes``), with what a still sensor's scene knows (``repair_frame``); and when
a temporal model's last clean frame lines up (``agreement``). Torch-free: the runtime, the torch models,
training and evaluation repair the same way."""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import crop_around
from d2sr.scene.evidence import SceneRepair

__all__ = [
    "AGREE_M",
    "AGREE_REL",
    "LINES_UP",
    "REFRESH_FRAMES",
    "REPAIR_PASSES",
    "Raw",
    "agreement",
    "check_passes",
    "guard",
    "recover_passes",
    "refill",
    "repair_frame",
]

# Do no harm (``guard``): a repair stays within the range of its trusted neighbours (``GUARD_PX`` around),
# widened by the sensor's noise (``KEEP_M`` + ``KEEP_REL`` x depth).
KEEP_M = 0.03
KEEP_REL = 0.02
GUARD_PX = 12
# ... and moves a return only when its value is farther from the repair than the model's own error: inside
# that band a right value cannot be told from a wrong one (the adapted D435 model's error at hit pixels of
# its held-out frames: lower quartile 10% of depth, median 25%). There, 25% fewer clean pixels changed at
# the same mask threshold, recall 0.306 -> 0.300; a partly hit stripe's returns in between are left alone.
LEAVE_REL = 0.10
# ... and leaves a lone return as it is: one with at most ``LONE_MAX`` other returns among the pixels within
# ``LONE_PX`` (9x9; outside the image: none). No surface around it says where it belongs. On the clean L515
# development frames the repair moved about 10 such returns a frame by metres (nearly all farther); leaving
# them cost 3.8 points of RMSE on one set (lab/notes/decisions.md).
LONE_PX = 4
LONE_MAX = 16
# Recovery runs the model again on its own repair: once the pixels it was sure of are filled in, the rest of
# a wide wrong surface stands out against them (a second pass lifted mask F1 0.63 -> 0.70 on sawtooth
# stripes written outside the project, and left clean frames as they were).
REPAIR_PASSES = 2
# A temporal model's last clean frame lines up with the frame (a sensor that held still) where at least
# ``LINES_UP`` of the pixels returning in both agree within ``AGREE_M`` + ``AGREE_REL`` x depth.
LINES_UP = 0.5
AGREE_M = 0.05
AGREE_REL = 0.02
# Repairing every frame with a temporal model, the detector only picks the last clean frame: it runs on a
# frame with none yet, one that does not line up with it, or when this many frames have passed since it
# last ran (unet8-temporal was trained with last clean frames 1-12 frames old).
REFRESH_FRAMES = 10


def guard(
    metres: np.ndarray,
    pred: np.ndarray,
    mask: np.ndarray,
    units: np.ndarray | None = None,
    scale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Do no harm: (pred, mask) limited to changes that matter and agree with the frame's trusted pixels.

    - A prediction is clamped to the range of the trusted returns (not masked) within ``GUARD_PX`` pixels,
      widened by ``KEEP_M`` + ``KEEP_REL`` x depth, so a repair never invents a surface nearer or farther
      than all of its neighbours. Where no trusted return is that close (a large hit region), it stands.
    - A returning pixel whose (clamped) prediction is within ``KEEP_M`` + ``LEAVE_REL`` x depth of its own
      value is left alone: the repair would move it by no more than the model's own error.
    - A lone return (at most ``LONE_MAX`` other returns within ``LONE_PX``) is left alone.

    Only masked pixels can be repaired, so only they are clamped (``pred`` is returned as is elsewhere).
    Works on one frame (H, W) or a batch (N, H, W), in metres. ``units``: the one frame as the sensor gave
    it (uint16, ``scale`` units per metre), where the caller has it: the neighbours' range is found on it
    in 60% of the time, with the same values (the conversion to metres keeps their order)."""
    if metres.ndim == 3:
        pairs = [guard(x, p, m) for x, p, m in zip(metres, pred, mask, strict=True)]
        return np.stack([p for p, _ in pairs]), np.stack([m for _, m in pairs])
    p = np.array(pred, np.float32)  # a contiguous copy, written below
    keep = np.zeros(mask.shape, bool)
    # The neighbours' range is needed only within GUARD_PX of a masked pixel (erode and dilate ignore
    # what lies beyond a crop's edge), and the rest only at the masked pixels: the cost follows the mask.
    crop = crop_around(mask, GUARD_PX)
    if crop is None:
        return p, keep
    rs, cs = crop
    x = np.ascontiguousarray(metres[rs, cs], np.float32)
    m = mask[rs, cs]
    returns = x > 0
    trusted = (returns & ~m).view(np.uint8)
    k = np.ones((2 * GUARD_PX + 1, 2 * GUARD_PX + 1), np.uint8)
    at = np.flatnonzero(m)
    # The trusted returns, the most (for the minimum) or 0 (for the maximum) elsewhere; cv2.copyTo: 6x
    # np.where. Where no return is trusted (hi 0) the range is not used.
    if units is not None and units.dtype == np.uint16:
        u = np.ascontiguousarray(units[rs, cs])
        lo = cv2.erode(cv2.copyTo(u, trusted, np.full_like(u, 65535)), k).ravel()[at]
        hi = cv2.dilate(cv2.copyTo(u, trusted, np.zeros_like(u)), k).ravel()[at]
        lo, hi = (np.divide(v, np.float32(scale), dtype=np.float32) for v in (lo, hi))  # as to_metres
    else:
        lo = cv2.erode(cv2.copyTo(x, trusted, np.full_like(x, np.inf)), k).ravel()[at]
        hi = cv2.dilate(cv2.copyTo(x, trusted, np.zeros_like(x)), k).ravel()[at]
    xi = x.ravel()[at]
    pc = p[rs, cs]  # a view into p
    pi = pc[m]
    tol = np.float32(KEEP_M) + np.float32(KEEP_REL) * xi
    pi = np.where(hi > 0, np.minimum(np.maximum(pi, lo - tol), hi + tol), pi)
    pc[m] = pi
    leave = np.float32(KEEP_M) + np.float32(LEAVE_REL) * xi
    # Returns counted as uint8 into uint16 (2.5x a float32 box filter); the crop's margin, GUARD_PX, holds
    # every masked pixel's LONE_PX neighbourhood, so only the image's own edges count as no return.
    side = 2 * LONE_PX + 1
    around = cv2.boxFilter(
        returns.view(np.uint8), cv2.CV_16U, (side, side), normalize=False, borderType=cv2.BORDER_CONSTANT
    )
    lone = around.ravel()[at] <= LONE_MAX + 1  # the count includes the pixel itself
    keep[rs, cs][m] = ~((xi > 0) & ((np.abs(pi - xi) <= leave) | lone))
    return p, keep


Raw = Callable[[np.ndarray, np.ndarray | None], tuple[np.ndarray, np.ndarray]]


def agreement(metres: np.ndarray, previous: np.ndarray | None) -> float:
    """Share of the pixels returning in both frames (metres, same shape) that agree within ``AGREE_M`` +
    ``AGREE_REL`` x depth; 0 with no earlier frame or no pixel returning in both."""
    if previous is None:
        return 0.0
    if previous.shape != metres.shape:
        raise InputError(f"the earlier frame is {previous.shape}, the frame {metres.shape}")
    ok = (metres > 0) & (previous > 0)
    n = np.count_nonzero(ok)
    if not n:
        return 0.0
    agree = np.abs(metres - previous) <= AGREE_M + AGREE_REL * metres  # whole arrays: no gathers
    return np.count_nonzero(agree & ok) / n


def check_passes(passes: int) -> int:
    if not 1 <= passes <= 8:
        raise ConfigError(f"passes must be in 1..8, got {passes}", "passes")
    return passes


def refill(metres: np.ndarray, pred: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What a pass after the first sees (``recover_passes``): the frame with the guarded repair filled in
    (float32 metres), and the pixels it filled."""
    p, keep = guard(metres, pred, mask)
    return np.where(keep, p, metres).astype(np.float32), keep


def recover_passes(
    raw: Raw, metres: np.ndarray, previous: np.ndarray | None, mask_logit: float, passes: int
) -> tuple[np.ndarray, np.ndarray]:
    """(predicted depth, mask), both (N, H, W), after ``passes`` runs of a recovery model (``raw``: metres,
    previous -> mask logits, depth). Each pass after the first sees the frame with the last pass's guarded
    repair filled in and keeps every pixel repaired so far; it stops early once a pass repairs nothing or
    finds no pixel the last one had not."""
    logit, pred = raw(metres, previous)
    mask = logit > mask_logit
    for _ in range(passes - 1):
        filled, keep = refill(metres, pred, mask)
        if not keep.any():
            break
        logit, pred = raw(filled, previous)
        grown = keep | (logit > mask_logit)
        found = (grown & ~mask).any()  # nothing new: a further pass would see much the same frame
        mask = grown
        if not found:
            break
    return pred, mask


def repair_frame(
    frames: np.ndarray,
    pred: np.ndarray,
    mask: np.ndarray,
    scale: float,
    scene: SceneRepair | None = None,
    metres: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(repaired frame in the input's units, mask of the pixels repaired): the guarded prediction inside
    the mask (``guard``), rounded to the input's units (uint16) or as computed (float32 metres, ``scale``
    1); the input itself everywhere else, bit for bit. A model repair that would move no return fills no
    hole either: the frame's holes are then the sensor's own. With ``scene``: its ``keep`` pixels are out
    of the mask (and so trusted by the guard), and its ``fill`` depths are written past the guard's
    model-error margin; only those that change the pixel count as repaired. ``metres``: ``frames`` in float32
    metres, where the caller has them (``d2sr.frames.base.to_metres`` gives the same values)."""
    if scene is not None:
        mask = mask & ~scene.keep
    if metres is None:
        metres = frames.astype(np.float32) / np.float32(scale)
    p, m = guard(metres, pred, mask, frames, scale)
    if not (m & (frames > 0)).any():  # whole frames: a quarter of the time of gathering the masked pixels
        # Holes alone are no sign of interference: an L515 loses ~18,000 returns a frame to its own
        # flicker, so a repair that would move no return fills no hole either (lab/notes/decisions.md).
        m = np.zeros_like(m)
    written = m
    if scene is not None:
        p, written = np.where(scene.fill, scene.depth, p), m | scene.fill
    out = frames.copy()
    at = np.flatnonzero(written)  # found once for the read and the write
    fixed = np.maximum(p.ravel()[at], 0) * np.float32(scale)
    put = fixed if frames.dtype.kind == "f" else np.clip(np.rint(fixed), 0, 65535).astype(np.uint16)
    out.ravel()[at] = put
    return out, m if scene is None else m | (scene.fill & (out != frames))
