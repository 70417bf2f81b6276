"""``"robust"``: d2sr's default controller. Decentralized: it sees only its own detections.

It is the paper's Algorithm 1 (``delta = hits in the first half of the window - hits in the second``,
the window moves by ``delta``) with one addition, for the one failure of Algorithm 1 that costs without
limit: the **symmetric stall**. When (almost) every frame of the window is hit and the halves are equal,
another window covers ours and Algorithm 1 never moves again. When that lasts ``patience`` (2) periods
in a row (a true stall persists; in a crowded period a window is only covered now and then), it jumps
with probability ``escape`` by a random amount (at least a window, at most the period minus a window),
so that of two identical sensors one usually leaves and the other stays. When an escape lands in another
covered place, the period is crowded rather than stalled, and the chance halves with each escape that
failed in a row: in a saturated period, jumping only reshuffles the overlap.

Why nothing else: the previous default (``damped``) added noise rejection, damping of reversals and a
congestion freeze. They win on average, but each loses to Algorithm 1 where the detector's signal is
sparse (low recall or hit probability) and the period is oversubscribed, as measured across deployment
assumptions with ``d2sr desync grid`` (docs/desync.md, docs/results/desync/grid/).
"""

from __future__ import annotations

from d2sr.desync.base import TOTAL_FRAMES, EscapingController

__all__ = ["RobustController"]


class RobustController(EscapingController):
    """Algorithm 1's push, and a randomized escape with backoff from a covered window."""

    name = "robust"

    def __init__(
        self,
        total_frames: int = TOTAL_FRAMES,
        active_frames: int = 15,
        seed: int | None = 0,
        offset: int | None = None,
        escape: float = 0.5,
        patience: int = 2,
    ) -> None:
        super().__init__(total_frames, active_frames, seed, offset, escape)
        self.patience = int(patience)  # covered periods in a row before an escape is tried
        self.stalled = 0
        self.failed = 0  # escapes in a row that landed in another covered place
        self._escaped = False

    def _shift(self, flags: list[bool]) -> int:
        n = self.active_frames
        hits = sum(flags)
        covered = hits >= n - 1
        if self._escaped:  # did the last escape find a freer place?
            self.failed = self.failed + 1 if covered else 0
            self._escaped = False
        half = n // 2
        delta = sum(flags[:half]) - sum(flags[n - half :])
        if delta or not covered:
            self.stalled = 0
            return delta  # Algorithm 1 (no hits, or balanced but not covered: stay)
        self.stalled += 1
        if self.stalled < self.patience or self.rng.random() >= self.escape * 0.5**self.failed:
            return 0
        self._escaped = True
        self.stalled = 0
        return self._escape_jump()
