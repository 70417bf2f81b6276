"""Who can interfere with whom, and when: the overlap graph of the timing world.

Edges are directed (``src``'s laser can corrupt ``dst``'s frames); views usually overlap both ways, so
the builders add both directions. ``live`` (edges x schedule steps) switches edges on and off over time
(a robot driving past fixed sensors) and ``present`` (sensors x steps) switches whole sensors (joining
and leaving); ``None`` means always. One schedule step lasts ``dt`` seconds; past the last step the last
column holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from d2sr.errors import ConfigError
from d2sr.graphs import components

__all__ = ["OverlapGraph"]


@dataclass(frozen=True)
class OverlapGraph:
    """Directed interference graph over ``n`` sensors, static or scheduled."""

    n: int
    src: np.ndarray
    dst: np.ndarray
    live: np.ndarray | None = None
    present: np.ndarray | None = None
    dt: float = 1.0
    #: Which sensors a scenario reports on (the moving robot's stream in the paper's moving scenario).
    focus: np.ndarray | None = None

    def __post_init__(self) -> None:
        src = np.asarray(self.src, dtype=np.int64).reshape(-1)
        dst = np.asarray(self.dst, dtype=np.int64).reshape(-1)
        object.__setattr__(self, "src", src)
        object.__setattr__(self, "dst", dst)
        if self.n <= 0:
            raise ConfigError(f"an overlap graph needs at least one sensor, got n={self.n}")
        if src.shape != dst.shape:
            raise ConfigError("overlap graph: src and dst must have the same length")
        if src.size and (min(src.min(), dst.min()) < 0 or max(src.max(), dst.max()) >= self.n):
            raise ConfigError(f"overlap graph: sensor index out of range 0..{self.n - 1}")
        if np.any(src == dst):
            raise ConfigError("overlap graph: a sensor cannot interfere with itself")
        if self.dt <= 0:
            raise ConfigError(f"overlap graph: dt must be positive, got {self.dt}")
        if self.live is not None and (self.live.ndim != 2 or self.live.shape[0] != src.size):
            raise ConfigError(f"overlap graph: live must be (edges={src.size}, steps), got {self.live.shape}")
        if self.present is not None and (self.present.ndim != 2 or self.present.shape[0] != self.n):
            raise ConfigError(f"overlap graph: present must be (sensors={self.n}, steps)")

    # ----------------------------------------------------------------- builders
    @classmethod
    def from_pairs(cls, n: int, pairs: list[tuple[int, int]] | np.ndarray, **kw: Any) -> OverlapGraph:
        """Undirected pairs -> edges both ways."""
        p = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        return cls(n, np.concatenate([p[:, 0], p[:, 1]]), np.concatenate([p[:, 1], p[:, 0]]), **kw)

    @classmethod
    def complete(cls, n: int) -> OverlapGraph:
        """Every sensor overlaps every other (the paper's stationary arc)."""
        a, b = np.triu_indices(n, k=1)
        return cls.from_pairs(n, np.stack([a, b], axis=1))

    @classmethod
    def moving_robot(cls, n: int, duration_s: float, seed: int = 0, loop_s: float = 20.0) -> OverlapGraph:
        """Sensor 0 rides a robot around a loop; sensors 1..n-1 are fixed and overlap each other.

        Each fixed sensor sees the robot along one arc of the loop (40-80% of it, random position), so
        the robot's overlap with the others comes and goes as in the paper's moving-robot set-up.
        """
        rng = np.random.default_rng(seed)
        steps = max(1, int(np.ceil(duration_s)))
        fixed = cls.complete(n - 1) if n > 1 else None
        src = [] if fixed is None else list(fixed.src + 1)
        dst = [] if fixed is None else list(fixed.dst + 1)
        live_rows = [np.ones(steps, dtype=bool)] * len(src)
        phase = (np.arange(steps) % loop_s) / loop_s
        for j in range(1, n):
            start, width = rng.uniform(0, 1), rng.uniform(0.4, 0.8)
            seen = ((phase - start) % 1.0) < width
            src += [0, j]
            dst += [j, 0]
            live_rows += [seen, seen]
        live = np.stack(live_rows) if live_rows else np.zeros((0, steps), dtype=bool)
        return cls(n, np.array(src), np.array(dst), live=live, dt=1.0, focus=np.array([0]))

    @classmethod
    def warehouse(
        cls,
        n: int,
        duration_s: float,
        seed: int = 0,
        neighbours: float = 4.0,
        mobile_fraction: float = 0.2,
        speed: float = 1.0,
    ) -> OverlapGraph:
        """Fixed sensors on shelves and robots driving between them, each overlapping a few neighbours.

        Sensors sit uniformly in a square sized so that a disc of the overlap radius holds ``neighbours``
        others on average; robots (``mobile_fraction``) bounce around at ``speed`` metres per second with
        a 2 m overlap radius, so their overlaps change every second.
        """
        rng = np.random.default_rng(seed)
        radius = 2.0
        side = float(np.sqrt(n * np.pi * radius**2 / max(neighbours, 1e-9)))
        steps = max(1, int(np.ceil(duration_s)))
        mobile = rng.random(n) < mobile_fraction
        pos = rng.uniform(0, side, (n, 2))
        heading = rng.uniform(0, 2 * np.pi, n)
        vel = speed * np.stack([np.cos(heading), np.sin(heading)], axis=1) * mobile[:, None]
        live_by_pair: dict[tuple[int, int], np.ndarray] = {}
        for t in range(steps):
            for a, b in _pairs_within(pos, radius):
                key = (int(a), int(b))
                row = live_by_pair.get(key)
                if row is None:
                    row = live_by_pair[key] = np.zeros(steps, dtype=bool)
                row[t] = True
            pos = pos + vel
            # bounce off the walls
            out = (pos < 0) | (pos > side)
            vel = np.where(out, -vel, vel)
            pos = np.clip(pos, 0, side)
        keys = np.array(list(live_by_pair), dtype=np.int64).reshape(-1, 2)
        rows = np.stack(list(live_by_pair.values())) if live_by_pair else np.zeros((0, steps), dtype=bool)
        static = rows.all(axis=1)
        live = np.concatenate([rows, rows]) if not static.all() else None
        g = cls.from_pairs(n, keys, live=live, dt=1.0)
        return g

    def replicate(self, copies: int) -> OverlapGraph:
        """``copies`` disconnected copies of this graph in one world (independent runs in one batch)."""
        if copies <= 0:
            raise ConfigError(f"copies must be positive, got {copies}")
        return OverlapGraph.disjoint([self] * copies)

    @classmethod
    def disjoint(cls, graphs: Sequence[OverlapGraph]) -> OverlapGraph:
        """Several graphs side by side in one world, sharing nothing (sensor indices shifted)."""
        if not graphs:
            raise ConfigError("disjoint() needs at least one graph")
        steps = max(a.shape[1] for g in graphs for a in (g.live, g.present, np.ones((1, 1))) if a is not None)
        shifts = np.cumsum([0] + [g.n for g in graphs[:-1]])
        any_live = any(g.live is not None for g in graphs)
        any_present = any(g.present is not None for g in graphs)

        def pad(a: np.ndarray | None, rows: int) -> np.ndarray:
            a = np.ones((rows, 1), dtype=bool) if a is None else a
            return np.concatenate([a, np.repeat(a[:, -1:], steps - a.shape[1], axis=1)], axis=1)

        focus = [g.focus + s for g, s in zip(graphs, shifts, strict=True) if g.focus is not None]
        return cls(
            int(sum(g.n for g in graphs)),
            np.concatenate([g.src + s for g, s in zip(graphs, shifts, strict=True)]),
            np.concatenate([g.dst + s for g, s in zip(graphs, shifts, strict=True)]),
            live=np.concatenate([pad(g.live, g.src.size) for g in graphs]) if any_live else None,
            present=np.concatenate([pad(g.present, g.n) for g in graphs]) if any_present else None,
            dt=graphs[0].dt,
            focus=np.concatenate(focus) if focus else None,
        )

    # ----------------------------------------------------------------- queries
    def union_pairs(self) -> np.ndarray:
        """Every pair that overlaps at some time, as (k, 2) undirected pairs."""
        ever = np.ones(self.src.size, dtype=bool) if self.live is None else self.live.any(axis=1)
        p = np.stack([self.src[ever], self.dst[ever]], axis=1)
        p.sort(axis=1)
        return np.unique(p, axis=0) if p.size else p.reshape(0, 2)

    def components(self) -> np.ndarray:
        """Connected component id of each sensor over the union of all edges."""
        return components(self.n, self.union_pairs())


def _pairs_within(pos: np.ndarray, radius: float) -> np.ndarray:
    """Pairs (a < b) closer than radius, via a grid of radius-sized cells (no O(n^2) distance matrix)."""
    cell = np.floor(pos / radius).astype(np.int64)
    key = cell[:, 0] * 1_000_003 + cell[:, 1]
    order = np.argsort(key, kind="stable")
    out = []
    buckets: dict[int, np.ndarray] = {}
    sk = key[order]
    starts = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1]])
    ends = np.r_[starts[1:], sk.size]
    for s, e in zip(starts, ends, strict=True):
        buckets[int(sk[s])] = order[s:e]
    for k, members in buckets.items():
        cx, cy = divmod(k, 1_000_003)
        near = [buckets.get((cx + dx) * 1_000_003 + cy + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
        cand = np.concatenate([m for m in near if m is not None])
        d = np.linalg.norm(pos[members][:, None, :] - pos[cand][None, :, :], axis=2)
        a, b = np.nonzero(d < radius)
        a, b = members[a], cand[b]
        keep = a < b
        out.append(np.stack([a[keep], b[keep]], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2), dtype=np.int64)
