"""The controller contract shared by every de-synchronization strategy.

A sensor's 1 s observation period has ``total_frames`` slots; its laser delivers ``active_frames`` (n)
consecutive frames starting at slot ``offset`` (wrapping at the period's end). After each period the
controller sees the n detections of that period, oldest first, and picks the next offset. Controllers see
nothing else: no other sensor, no clock, no count of sensors. That is what makes them decentralized.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import cast

import numpy as np

from d2sr.errors import ConfigError

__all__ = [
    "DEFAULT_ACTIVE",
    "TOTAL_FRAMES",
    "Controller",
    "EscapingController",
    "check_flags",
    "check_window",
]

TOTAL_FRAMES = 30  # slots of one 1 s observation period: a 30 fps sensor's frames
# Frames a period a sensor runs unless told (the paper's 20%): run, the node, the triggers, the demo.
DEFAULT_ACTIVE = 6


def check_window(total_frames: int, active_frames: int) -> None:
    """Reject windows that do not fit in the period."""
    if isinstance(total_frames, bool) or not isinstance(total_frames, int | np.integer) or total_frames <= 0:
        raise ConfigError(f"total_frames must be a positive integer, got {total_frames!r}")
    if isinstance(active_frames, bool) or not isinstance(active_frames, int | np.integer):
        raise ConfigError(f"active_frames must be an integer, got {active_frames!r}")
    if not 0 < active_frames <= total_frames:
        raise ConfigError(f"active_frames must be in 1..{total_frames} (total_frames), got {active_frames}")


def check_flags(flags: Sequence[bool] | np.ndarray, n: int) -> list[bool]:
    """The period's n detections as plain bools; anything else is an error, never a silent fix."""
    if len(flags) != n:
        raise ConfigError(f"update() needs the {n} detections of the window, got {len(flags)}")
    if isinstance(flags, np.ndarray) and flags.dtype == np.bool_ and flags.ndim == 1:
        return cast(list[bool], flags.tolist())  # the timing world's fast path
    out = []
    for f in flags:
        if isinstance(f, bool | np.bool_) or (isinstance(f, int | np.integer) and f in (0, 1)):
            out.append(bool(f))
        else:
            raise ConfigError(f"detections must be booleans (or 0/1), got {f!r}")
    return out


class Controller(ABC):
    """One sensor's duty-cycle controller: ``offset`` now, ``update(flags)`` at each period's end."""

    name: str = ""

    def __init__(
        self,
        total_frames: int = TOTAL_FRAMES,
        active_frames: int = 15,
        seed: int | None = 0,
        offset: int | None = None,
    ) -> None:
        check_window(total_frames, active_frames)
        self.total_frames = int(total_frames)
        self.active_frames = int(active_frames)
        self.rng = np.random.default_rng(seed)
        # Random initial offset (Algorithm 1): sensors switched on together must not start aligned.
        start = int(self.rng.integers(total_frames))
        if offset is not None:
            if isinstance(offset, bool) or not isinstance(offset, int | np.integer):
                raise ConfigError(f"offset must be an integer, got {offset!r}")
            if not 0 <= offset < total_frames:
                raise ConfigError(f"offset must be in 0..{total_frames - 1}, got {offset}")
            start = int(offset)
        self._offset = start

    @property
    def offset(self) -> int:
        """First active slot of the next period, in ``[0, total_frames)``."""
        return self._offset

    def update(self, flags: Sequence[bool] | np.ndarray) -> int:
        """Take the detections of the period that ended (time order) and return the new offset."""
        checked = check_flags(flags, self.active_frames)
        shift = self._shift(checked)
        self._offset = (self._offset + int(shift)) % self.total_frames
        return self._offset

    @abstractmethod
    def _shift(self, flags: list[bool]) -> int:
        """Slots to move the window: positive = later in the period, negative = earlier."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(n={self.active_frames}/{self.total_frames}, offset={self._offset})"


class EscapingController(Controller):
    """A controller that, besides its own rule, can escape a window another one covers: ``escape`` is
    the probability of trying, ``_escape_jump`` the random move (shared by ``robust`` and ``damped``)."""

    def __init__(
        self,
        total_frames: int = TOTAL_FRAMES,
        active_frames: int = 15,
        seed: int | None = 0,
        offset: int | None = None,
        escape: float = 0.5,
    ) -> None:
        super().__init__(total_frames, active_frames, seed, offset)
        if not 0.0 <= escape <= 1.0:
            raise ConfigError(f"escape must be a probability in [0, 1], got {escape}")
        self.escape = escape

    def _escape_jump(self) -> int:
        """A random move out of a covered window: at least a window, at most the period minus one."""
        n, t = self.active_frames, self.total_frames
        lo = min(n, t // 2)
        return int(self.rng.integers(lo, max(lo, t - n) + 1))
