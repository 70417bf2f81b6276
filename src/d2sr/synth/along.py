"""Depth carried along the colour frame into what the camera newly sees (numpy and OpenCV only).

After the warp of the last real frame and the background fill, what the camera now sees but never measured
is still empty. Depth spreads into it from the measured pixels around, at 1/8 of the side, each step taking
the colour-weighted mean of its filled 8-neighbours (weights exp(-|Lab difference|^2 / 2 sigma^2)): it
follows regions of the colour it came from and stops at colour edges. Two passes, a tight tolerance first
and a looser one over what is left, each with its own lower confidence (``STEPS``). Nothing comes in from
beyond the frame's edge.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["LEVEL", "REACH", "STEPS", "fill_along_colour"]

#: (colour tolerance sigma in Lab units, confidence of what that pass fills): tight, then looser. Chosen on
#: the hand-held D435 sequence, as shipped and with every second frame dropped (a turn twice as fast): the
#: tight pass alone left 86% of hold-last's coverage on the fast turn, one loose pass (sigma 10) raised the
#: error of the slow one to 56% of hold-last's (lab/notes/decisions.md, 2026-11-28).
STEPS: tuple[tuple[float, float], ...] = ((4.0, 0.25), (7.0, 0.1))
LEVEL = 8  # the propagation runs at 1/LEVEL of the side: 80x60 for 640x480
REACH = 60  # steps per pass: up to 480 px at full resolution
_NEIGHBOURS = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]


def _lab(colour: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``colour`` (BGR uint8, or grey) in Lab at ``size`` (w, h), padded by one pixel on every side."""
    if colour.ndim == 3:
        lab = cv2.cvtColor(colour, cv2.COLOR_BGR2LAB).astype(np.float32)
    else:  # grey: lightness only
        lab = np.repeat((colour.astype(np.float32) * np.float32(100 / 255))[..., None], 3, 2)
    small = cv2.resize(lab, size, interpolation=cv2.INTER_AREA)
    return np.pad(small, ((1, 1), (1, 1), (0, 0)), mode="edge")


def _colour_steps(lab: np.ndarray) -> list[np.ndarray]:
    """Squared Lab distance from each coarse pixel to each of its 8 neighbours (``lab`` padded)."""
    sh, sw = lab.shape[0] - 2, lab.shape[1] - 2
    centre = lab[1:-1, 1:-1]
    return [
        ((centre - lab[1 + dy : 1 + dy + sh, 1 + dx : 1 + dx + sw]) ** 2).sum(2) for dy, dx in _NEIGHBOURS
    ]


def _pass(metres: np.ndarray, steps: list[np.ndarray], sigma: float) -> np.ndarray:
    """``metres`` with its holes filled along the coarse colour (``_colour_steps``) at one tolerance."""
    h, w = metres.shape
    sh, sw = steps[0].shape
    hole = metres == 0
    valid = (~hole).astype(np.float32)
    dsum = cv2.resize(metres * valid, (sw, sh), interpolation=cv2.INTER_AREA)
    vsum = cv2.resize(valid, (sw, sh), interpolation=cv2.INTER_AREA)
    padded = np.zeros((sh + 2, sw + 2), np.float32)  # a border of no depth
    core = padded[1:-1, 1:-1]
    core[...] = np.where(vsum > 0.5, dsum / np.maximum(vsum, 1e-6), 0)
    inv = np.float32(-1 / (2 * sigma * sigma))
    weights = [np.exp(d * inv) for d in steps]
    for _ in range(REACH):
        num, den = np.zeros_like(core), np.zeros_like(core)
        for (dy, dx), wgt in zip(_NEIGHBOURS, weights, strict=True):
            near = padded[1 + dy : 1 + dy + sh, 1 + dx : 1 + dx + sw]
            wn = wgt * (near > 0)
            num += wn * near
            den += wn
        new = (core == 0) & (den > 0.5)
        if not new.any():
            break
        core[new] = num[new] / den[new]
    out = metres.copy()
    up = cv2.resize(core, (w, h), interpolation=cv2.INTER_NEAREST)
    out[hole] = up[hole]
    return out


def fill_along_colour(
    metres: np.ndarray, confidence: np.ndarray, colour: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``metres`` (float32, 0 = empty) with its holes filled along ``colour`` (same size, BGR or grey), and
    ``confidence`` with each filled pixel's set to its pass's (``STEPS``); both new arrays."""
    out, conf = metres.astype(np.float32), confidence.astype(np.float32)  # copies
    if not (out == 0).any() or not (out > 0).any():
        return out, conf
    h, w = out.shape
    steps = _colour_steps(_lab(colour, (max(1, w // LEVEL), max(1, h // LEVEL))))
    for sigma, level in STEPS:
        filled = _pass(out, steps, sigma)
        conf[(out == 0) & (filled > 0)] = np.float32(level)
        out = filled
    return out, conf
