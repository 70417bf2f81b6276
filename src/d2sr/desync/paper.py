"""The paper's Algorithm 1 (dynamic duty cycle), exactly.

At each period's end, ``delta = (interfered frames in the first half of the window) - (in the second
half)`` and the window moves by ``delta`` slots: interference early in the window means the interferer
sits before us, so we move later (``delta > 0``); interference late means it sits after us, so we move
earlier (``delta < 0``). This reproduces Fig. 5: with n = 12, L1 interfered in its second half moves back
4 slots and L2 interfered in its first half moves forward 4.

Odd n: the halves are the first and the last ``n // 2`` frames; the middle frame counts in neither, so
the rule stays symmetric (a window hit exactly in the middle does not drift one way).
"""

from __future__ import annotations

from d2sr.desync.base import Controller

__all__ = ["PaperController"]


class PaperController(Controller):
    """Algorithm 1 of the D2SR paper: shift by first-half minus second-half interfered frames."""

    name = "d2sr"

    def _shift(self, flags: list[bool]) -> int:
        half = self.active_frames // 2
        return sum(flags[:half]) - sum(flags[self.active_frames - half :])
