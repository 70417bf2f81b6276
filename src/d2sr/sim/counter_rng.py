"""Counter-based uniform numbers: the draw for (seed, stream, sensor, frame) never depends on call order.

The timing world draws its randomness per frame from this hash instead of a sequential generator, so two
runs that differ only in their controllers see the same hits, misses and drops for the same frames
(common random numbers): comparisons between controllers are paired, and their noise mostly cancels.
"""

from __future__ import annotations

import numpy as np

__all__ = ["uniform"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_SENSOR = np.uint64(0xD6E8FEB86659FD93)
_FRAME = np.uint64(0xA0761D6478BD642F)
_STREAM = np.uint64(0xE7037ED1A0B428DB)


def _mix(z: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser: a bijection of uint64 with good avalanche."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def uniform(seed: int, sensor: np.ndarray, frame: np.ndarray, streams: int = 1) -> np.ndarray:
    """Uniform numbers in [0, 1), shape (streams, len(sensor)), fixed by seed, sensor, frame and stream."""
    with np.errstate(over="ignore"):
        base = _mix(np.array([seed & 0xFFFFFFFFFFFFFFFF], dtype=np.uint64) * _GOLDEN + _STREAM)
        z = _mix(base ^ (sensor.astype(np.uint64) * _SENSOR) + frame.astype(np.uint64) * _FRAME)
        out = _mix(z[None, :] + np.arange(1, streams + 1, dtype=np.uint64)[:, None] * _GOLDEN)
    return (out >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)
