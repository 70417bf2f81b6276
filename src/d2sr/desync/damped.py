"""``"damped"``: d2sr's default controller before ``robust`` (``d2sr.desync.DEFAULT_CONTROLLER``), kept as
an option. Decentralized: it sees only its own detections.

It keeps Algorithm 1's core, a push away from where interference falls in the window
(``delta = hits in the first half - hits in the second half``), because that push balances a crowded
period well: a window squeezed from both sides settles where both overlaps are equal. It fixes the
rule's four failure modes, each measured in the sweep (docs/desync.md):

1. **Stay put once clean, and under noise.** No detections: no move (as Algorithm 1). A single flag
   in the middle of the window is taken for a false alarm: real interference from a neighbour's
   window enters at an edge of ours or covers several frames.
2. **Balanced squeeze is a steady state, not a stall.** Hits on both sides in equal number
   (``delta = 0``) mean the window is as well placed as its neighbours allow: stay.
3. **Symmetric stall: randomized escape.** When (almost) every frame is hit and the halves are equal,
   another window covers ours and Algorithm 1 would sit there forever. Jump by a random amount (at
   least a window, at most the period minus a window) with probability ``escape``, so that of two
   identical sensors one usually leaves and the other stays.
4. **Oscillation: damping.** When the push reverses the previous move, halve it (at least one slot):
   two windows that overshoot past each other meet in the middle instead of bouncing.
5. **Congestion freeze.** It keeps a running estimate of how crowded the period is (``load``, the
   fraction of its frames flagged, averaged over about five periods). Above ``freeze`` (75%) a window
   squeezed from both sides stops pushing: in a saturated period pushing only spreads the windows
   evenly, which covers every slot twice; random static offsets do better there, and so does staying.
   ``load`` is also what a user reads to learn that the frame rate is too high for the room.

The number of interferers is not needed: with more of them, more of the window is hit and the pushes
from both sides add up.
"""

from __future__ import annotations

from d2sr.desync.base import TOTAL_FRAMES, EscapingController

__all__ = ["DampedController"]


class DampedController(EscapingController):
    """Algorithm 1's push with noise rejection, randomized escape and damping (see module docstring)."""

    name = "damped"

    def __init__(
        self,
        total_frames: int = TOTAL_FRAMES,
        active_frames: int = 15,
        seed: int | None = 0,
        offset: int | None = None,
        escape: float = 0.5,
        freeze: float = 0.75,
    ) -> None:
        super().__init__(total_frames, active_frames, seed, offset, escape)
        self.freeze = freeze
        self.load = 0.0  # running fraction of our frames flagged: how crowded the period is
        self.last = 0  # the previous move, to spot a reversal

    def _shift(self, flags: list[bool]) -> int:
        self.last = self._decide(flags)
        return self.last

    def _decide(self, flags: list[bool]) -> int:
        n = self.active_frames
        hits = sum(flags)
        self.load += 0.2 * (hits / n - self.load)
        if hits == 0 or (hits == 1 and not (flags[0] or flags[-1])):
            return 0
        half = n // 2
        head, tail = sum(flags[:half]), sum(flags[n - half :])
        if head == tail:
            if hits < n - 1 or self.rng.random() >= self.escape:
                return 0
            return self._escape_jump()
        if head and tail and self.load > self.freeze:
            return 0
        delta = head - tail
        if self.last and (delta > 0) != (self.last > 0):
            delta = int(delta / 2) or (1 if delta > 0 else -1)
        return delta
