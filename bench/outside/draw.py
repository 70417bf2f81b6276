"""The outside sets' shared draws: each set's stream of random numbers (``SALTS``), its two models
(``KINDS``), and the helpers their interference functions share."""

from __future__ import annotations

import numpy as np

SEED = 5_000_000
# Each set's stream of random numbers.
SALTS = {
    "a": 0x0E7,
    "b": 0xB0B,
    "c": 0xC0C,
    "d": 0xD0D,
    "e": 0xE0E,
    "f": 0xF0F,
    "g": 0x70F,
    "h": 0x4A4,
    "i": 0x1D5,
    "k": 0xF10,
    "l": 0x5E3,
    "m": 0x3A1,
    "n": 0x9E7,
    "o": 0x0B1,
    "p": 0x5A7,
    "q": 0x7C2,
    "r": 0x2D9,
    "s": 0x6F3,
    "t": 0x7A5,
    "u": 0x2C7,
    "v": 0x91B,
    "w": 0x4E5,
    "x": 0x8D3,
    "y": 0x3B9,
    "z": 0xA52,
    "aa": 0x6A1,
    "ab": 0x2B8,
    "ac": 0x4C6,
}
# Each set's two models; a frame's first random draw (< 0.5: the first) picks one (``kind``).
KINDS = {
    "a": ("rings", "sawtooth"),
    "b": ("lissajous", "ghost tiles"),
    "c": ("phantom", "echo bursts"),
    "d": ("bloom", "unwrapping"),
    "e": ("moire beat", "row tearing"),
    "f": ("dot lattice", "gray-code stripes"),
    "g": ("tof lit patch", "tof lit surface"),
    "h": ("multipath", "phase crosstalk"),
    "i": ("blackout sparkle", "scan ghost"),
    "k": ("flood noise", "diagonal comb"),
    "l": ("row skew", "mirror ghost"),
    "m": ("range walk", "phase wedge"),
    "n": ("window ghost", "column crosstalk"),
    "o": ("flying edges", "blotch field"),
    "p": ("spark segments", "echo rings"),
    "q": ("dash rain", "grid glints"),
    "r": ("dark fill", "edge spray"),
    "s": ("speckle veil", "beam scatter"),
    "t": ("range staircase", "clamped plane"),
    "u": ("phase beat", "readout bands"),
    "v": ("halo ring", "offset cells"),
    "w": ("flare streak", "echo shadow"),
    "x": ("block crosstalk", "ring dropout"),
    "y": ("far haze", "edge bleed"),
    "z": ("row interleave", "ripple"),
    "aa": ("late echoes", "pile-up band"),
    "ab": ("range folding", "pulse curtains"),
    "ac": ("bright object", "wiggle bands"),
}


def _start(
    frame: np.ndarray, scale: float, seed: int, which: str
) -> tuple[np.random.Generator, int, int, np.ndarray]:
    """Set ``which``'s random numbers for the frame of ``seed``, the frame's size, and its depth in metres."""
    h, w = frame.shape
    return np.random.default_rng([seed, SALTS[which]]), h, w, frame.astype(np.float64) / scale


def _ellipse(rng: np.random.Generator, y: np.ndarray, x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Sets I and K: an ellipse covering ``lo``-``hi`` of the view, of random aspect, centred in its middle
    three fifths: each pixel's squared distance from its centre in units of its radii (< 1 inside)."""
    h, w = y.shape
    area = rng.uniform(lo, hi) * h * w
    ry = np.sqrt(area / np.pi / rng.uniform(0.6, 1.6))
    rx = area / np.pi / ry
    ey, ex = rng.uniform(0.2, 0.8) * h, rng.uniform(0.2, 0.8) * w
    out: np.ndarray = ((y - ey) / ry) ** 2 + ((x - ex) / rx) ** 2
    return out


def _written(frame: np.ndarray, new: np.ndarray, where: np.ndarray, scale: float) -> np.ndarray:
    """Sets B-F: the uint16 frame with ``new`` (metres; 0: no return) written at the pixels ``where``."""
    out = np.where(where, np.where(new > 0, np.clip(np.rint(new * scale), 1, 65535), 0), frame)
    return out.astype(np.uint16)
