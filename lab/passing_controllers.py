"""Probe (issue 68): controller variants tried on a robot passing a ring, and what each costs in the
stationary assumption grid. None shipped (lab/notes/decisions.md, 2026-11-28).

The ring: ``d2sr.sim.passing`` with 4 fixed sensors and a robot at 6 of 30 frames, the sweep's default
assumptions, 60 rooms of 120 s; the steady (second-half) interfered share of the robot's frames and of the
fixed sensors'. ``--grid``: the variant and Algorithm 1 in every cell of ``d2sr desync grid`` (23 rooms x 12
settings, 20 rooms x 60 s), counting cells where the variant loses by more than 0.3 points.

Variants (each is ``robust`` plus one rule):
- ``quiet_damped``: a single flag away from the window's edges is taken for a false alarm, and a push that
  reverses the previous one is halved (``damped``'s noise rejection and damping);
- ``squeeze``: a window hit at both ends with the halves balanced counts as stalled, as a covered one does;
- ``pinned``: a window hit at both ends counts as stalled whatever the halves say (a squeeze that oscillates);
- ``trial``: a window hit at both ends for 3 periods tries a jump and goes back when the next period is not
  better;
- ``nudge``: the first escape from a stall is one slot, a jump only when that fails.

Run:  python -m lab.passing_controllers --variant pinned [--grid]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from d2sr.desync import CONTROLLERS
from d2sr.desync.robust import RobustController
from d2sr.sim.passing import passing_rooms
from d2sr.sim.timing import TimingSettings, simulate


def _halves(flags: list[bool], n: int) -> tuple[int, int]:
    half = n // 2
    return sum(flags[:half]), sum(flags[n - half :])


class QuietDamped(RobustController):
    name = "quiet_damped"
    last = 0

    def _shift(self, flags: list[bool]) -> int:
        n = self.active_frames
        if sum(flags) == 1 and not (flags[0] or flags[-1]):
            flags = [False] * n
        d = super()._shift(flags)
        if d and self.last and (d > 0) != (self.last > 0) and abs(d) < n:
            d = int(d / 2) or (1 if d > 0 else -1)
        self.last = d
        return d


class Squeeze(RobustController):
    name = "squeeze"
    any_delta = False

    def __init__(self, *a: object, **k: object) -> None:
        super().__init__(*a, **k)  # type: ignore[arg-type]
        self._before = 0

    def _shift(self, flags: list[bool]) -> int:
        n, hits = self.active_frames, sum(flags)
        head, tail = _halves(flags, n)
        delta = head - tail
        stuck = hits >= n - 1 or bool(head and tail and (self.any_delta or hits >= 2))
        if self._escaped:
            self.failed = self.failed + 1 if hits and hits >= self._before else 0
            self._escaped = False
        if not stuck or (delta and not self.any_delta):
            self.stalled = 0
            return delta
        self.stalled += 1
        if self.stalled < self.patience or self.rng.random() >= self.escape * 0.5**self.failed:
            return delta
        self._escaped, self._before, self.stalled = True, hits, 0
        return self._escape_jump()


class Pinned(Squeeze):
    name = "pinned"
    any_delta = True


class Trial(RobustController):
    name = "trial"

    def __init__(self, *a: object, **k: object) -> None:
        super().__init__(*a, **k)  # type: ignore[arg-type]
        self._before = self._jump = self.pinned = self.tried = 0

    def _shift(self, flags: list[bool]) -> int:
        n, hits = self.active_frames, sum(flags)
        head, tail = _halves(flags, n)
        if self._jump:  # judge the trial
            jump, self._jump = self._jump, 0
            if hits >= self._before:
                self.tried += 1
                self.pinned = 0
                return -jump
            self.tried = 0
        pinned = bool(head and tail) and hits < n - 1
        self.pinned = self.pinned + 1 if pinned else 0
        if pinned and self.pinned >= 3 and self.rng.random() < self.escape * 0.5**self.tried:
            self.pinned, self._before = 0, hits
            self._jump = self._escape_jump()
            return self._jump
        return super()._shift(flags)


class Nudge(RobustController):
    name = "nudge"
    nudged = False

    def _escape_jump(self) -> int:
        if not self.nudged:
            self.nudged = True
            return 1 if self.rng.random() < 0.5 else -1
        self.nudged = False
        return super()._escape_jump()

    def _shift(self, flags: list[bool]) -> int:
        if self.nudged and sum(flags) < self.active_frames - 1:
            self.nudged = False
        return super()._shift(flags)


VARIANTS = {c.name: c for c in (QuietDamped, Squeeze, Pinned, Trial, Nudge)}


def ring(controller: str, rooms: int = 60, seconds: float = 120.0) -> dict[str, float]:
    """Steady interfered shares of the robot's frames and of the fixed sensors' on the ring."""
    graph = passing_rooms("ring", 5, seconds, rooms)
    run = simulate(graph, controller, TimingSettings.make(active_frames=6), seconds, seed=0)
    robot = np.arange(graph.n) % 5 == 0
    half = run.periods // 2
    return {
        "robot_steady": round(run.ratio(np.flatnonzero(robot), half), 4),
        "fixed_steady": round(run.ratio(np.flatnonzero(~robot), half), 4),
        "whole": round(run.ratio(), 4),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", required=True, choices=[*VARIANTS, "robust", "d2sr", "damped"])
    ap.add_argument("--grid", action="store_true", help="also the stationary assumption grid (10-15 min)")
    args = ap.parse_args()
    CONTROLLERS.update(VARIANTS)  # the pool's workers fork with the registry as it is here
    out: dict[str, object] = {"variant": args.variant, "ring": ring(args.variant)}
    if args.grid:
        from d2sr.eval.assumptions import run_grid, summary

        sets, res = run_grid([args.variant, "d2sr"])
        s = summary(sets, res, args.variant)
        out["grid"] = {k: s[k] for k in ("worst", "mean_diff_points", "cells_losing_over_0.3")}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
