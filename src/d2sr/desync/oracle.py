"""Time-sharing with global knowledge: the reference, not a decentralized method.

An ``OracleController`` does nothing by itself: the timing world sees its ``global_knowledge`` flag and,
at each of the sensor's period ends, assigns the offset that its ``OracleScheduler`` computes from every
sensor's true phase, clock rate and window length. For each connected group of sensors the scheduler
searches a layout of laser windows on the real-time circle (one period) that minimizes the expected
number of interfered frames, by coordinate descent from several starts (windows packed back to back,
spread evenly, random). With slack it finds a layout with no overlap; oversubscribed, it places the
unavoidable overlap where it costs least (a neighbour's start-up over our last frames, or sacrificing
one window entirely when the period is hopelessly full). Groups larger than ``max_search`` sensors get
greedy-colouring packing instead (sensors of one colour share a slice of the period).
"""

from __future__ import annotations

import numpy as np

from d2sr.desync.base import Controller
from d2sr.graphs import components, greedy_colouring

__all__ = ["OracleController", "OracleScheduler"]


class OracleController(Controller):
    """Takes the offset the world's oracle scheduler assigns; never moves on its own."""

    name = "oracle"
    global_knowledge = True

    def _shift(self, flags: list[bool]) -> int:
        return 0

    def assign(self, offset: int) -> None:
        """Set the next offset (called by the timing world, which knows every sensor)."""
        self._offset = int(offset) % self.total_frames


class OracleScheduler:
    """Per group of overlapping sensors, target laser-start times on the real-time circle.

    Times are seconds; sensor i's local slot g starts at ``t0[i] + g * tau[i]``; its laser runs
    ``setup`` slots before its ``n[i]`` frames. Targets are re-derived when drift has moved the slot grids
    by more than an eighth of a slot (``refresh_s``).
    """

    bins_per_slot = 8
    max_search = 8  # components up to this size get a searched layout, larger ones a packed one
    refresh_s = 30.0  # seconds before the targets are derived again as the slot grids drift

    def __init__(
        self,
        pairs: np.ndarray,
        t0: np.ndarray,
        tau: np.ndarray,
        n: np.ndarray,
        setup: int,
        total_frames: int,
        hit_prob: float = 0.9,
        seed: int = 0,
    ) -> None:
        self.t0, self.tau, self.n = np.asarray(t0, float), np.asarray(tau, float), np.asarray(n)
        self.setup, self.total = int(setup), int(total_frames)
        self.miss = 1.0 - hit_prob
        self.rng = np.random.default_rng(seed)
        size = len(self.t0)
        self.pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        self.component = components(size, self.pairs)
        self.colour = greedy_colouring(size, self.pairs)
        self.period = self.total * float(np.mean(self.tau))
        self._targets: dict[int, tuple[float, dict[int, float]]] = {}

    def offset_for(self, i: int, now: float, offsets: np.ndarray) -> int:
        """Sensor i's offset for the period it starts at time ``now``, given everyone's current offsets."""
        comp = int(self.component[i])
        cached = self._targets.get(comp)
        if cached is None or now - cached[0] > self.refresh_s:
            members = np.flatnonzero(self.component == comp)
            cached = (now, self._layout(members, now, offsets[members]))
            self._targets[comp] = cached
        target = cached[1][i]  # laser start, seconds on the circle
        # first frame slot: the slot boundary nearest target, plus setup; modulo the period
        g = round((target - self.t0[i]) / self.tau[i])
        return int((g + self.setup) % self.total)

    # ------------------------------------------------------------------ layouts
    def _layout(self, members: np.ndarray, now: float, current: np.ndarray) -> dict[int, float]:
        if members.size == 1:
            m = int(members[0])
            return {m: float(self.t0[m] + (int(current[0]) - self.setup) * self.tau[m])}
        if members.size > self.max_search:
            return self._packed_by_colour(members, now)
        return self._searched(members, now, current)

    def _period_start(self, m: int, now: float) -> float:
        """Where sensor m's current period started, in seconds on the circle (offsets count from there)."""
        g = np.floor((now - self.t0[m]) / (self.total * self.tau[m])) * self.total
        return float((self.t0[m] + g * self.tau[m]) % self.period)

    def _packed_by_colour(self, members: np.ndarray, now: float) -> dict[int, float]:
        start = self._period_start(int(members[0]), now)
        out: dict[int, float] = {}
        for c in sorted({int(self.colour[m]) for m in members}):
            ends = []
            for m in members[self.colour[members] == c]:
                slot = self.tau[m]
                phase = self._period_start(int(m), now)
                s = start + (phase - start) % slot
                out[int(m)] = s
                ends.append(s + (self.n[m] + self.setup) * slot)
            start = max(ends)
        return out

    def _searched(self, members: np.ndarray, now: float, current: np.ndarray) -> dict[int, float]:
        """Coordinate descent over each member's slot offset on a binned circle, best of several starts."""
        bps, total, setup = self.bins_per_slot, self.total, self.setup
        bins = total * bps
        k = members.size
        local = {int(m): j for j, m in enumerate(members)}
        adj = np.zeros((k, k), dtype=bool)
        for a, b in self.pairs:
            if int(a) in local and int(b) in local:
                adj[local[int(a)], local[int(b)]] = adj[local[int(b)], local[int(a)]] = True
        base = np.array([round(self._period_start(int(m), now) / self.period * bins) for m in members])
        # laser[j, o] and frames[j, o] for each member j and slot offset o, as bin masks on the circle
        laser = np.zeros((k, total, bins), dtype=bool)
        frame_id = np.full((k, total, bins), -1, dtype=np.int64)
        for j, m in enumerate(members):
            n = int(self.n[m])
            for o in range(total):
                first = base[j] + o * bps
                # one guard bin each side keeps slack layouts apart while clocks drift between re-plans
                on = (first - setup * bps - 1 + np.arange((n + setup) * bps + 2)) % bins
                laser[j, o, on] = True
                fr = (first + np.arange(n * bps)) % bins
                frame_id[j, o, fr] = np.arange(n * bps) // bps

        def cost_of(j: int, offs: np.ndarray) -> float:
            """Expected interfered frames of member j given everyone's offsets."""
            others = [u for u in range(k) if u != j and adj[j, u]]
            if not others:
                return 0.0
            fid = frame_id[j, offs[j]]
            n = int(self.n[members[j]])
            hits = np.zeros(n)
            sel = fid >= 0
            for u in others:
                per_frame = np.bincount(fid[sel], weights=laser[u, offs[u]][sel], minlength=n)
                hits += per_frame > 0  # any touch counts: bins are coarse, the oracle can be strict
            return float(np.sum(1.0 - self.miss**hits))

        def total_cost(offs: np.ndarray) -> float:
            return sum(cost_of(j, offs) for j in range(k))

        # the layout in use comes first and wins ties: re-planning must not shuffle a good layout
        starts = [np.asarray(current, dtype=np.int64) % total]
        packed, even = [], []
        pos = 0.0
        for j, m in enumerate(members):
            packed.append(int(np.ceil(pos - base[j] / bps + setup)) % total)
            pos = (packed[-1] - setup) + base[j] / bps + int(self.n[m]) + setup
            even.append(round(j * total / k - base[j] / bps + setup) % total)
        starts += [np.array(packed), np.array(even)]
        starts += [self.rng.integers(total, size=k) for _ in range(3)]
        best, best_cost = starts[0], np.inf
        for offs in starts:
            offs = offs.copy()
            cost_now = total_cost(offs)
            for _ in range(6):
                improved = False
                for j in range(k):
                    trial_costs = []
                    for o in range(total):
                        offs_try = offs.copy()
                        offs_try[j] = o
                        trial_costs.append(total_cost(offs_try))
                    o_best = int(np.argmin(trial_costs))
                    if trial_costs[o_best] < cost_now - 1e-9:
                        offs[j], cost_now, improved = o_best, trial_costs[o_best], True
                if not improved:
                    break
            if cost_now < best_cost - 0.5:
                best, best_cost = offs.copy(), cost_now
        out = {}
        for j, m in enumerate(members):
            out[int(m)] = (base[j] + (int(best[j]) - setup) * bps) / bins * self.period
        return out
