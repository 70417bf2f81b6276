"""Robots driving past fixed sensors: overlap graphs where who meets whom changes every few periods.

Fixed sensors stand in a ``"ring"`` (each overlaps its two ring neighbours) or a ``"row"`` (each overlaps
the one before and after it). A robot stops beside two neighbouring fixed sensors at a time, overlapping
both, and moves on to the next pair every ``stay_s`` seconds: round the ring, or along the row and back.
A second robot drives the other way from the other end, so the two cross; robots overlap each other while
they stand beside a common fixed sensor. By the time a robot arrives, the pair it meets has settled
around each other: the robot must find their gap without breaking it.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from d2sr.errors import ConfigError
from d2sr.sim.overlap import OverlapGraph

__all__ = ["WORLDS", "Layout", "passing", "passing_rooms"]

Layout = Literal["ring", "row"]
#: The passing worlds by name: a robot passing a ring, a robot passing a row (and back), two robots crossing.
WORLDS = ("ring", "row", "crossing")


def _fixed_pairs(fixed: int, layout: Layout) -> list[tuple[int, int]]:
    """Neighbouring fixed sensors (indices 0..fixed-1), each pair once."""
    pairs = {(i, i + 1) for i in range(fixed - 1)}
    if layout == "ring" and fixed > 2:
        pairs.add((0, fixed - 1))
    return sorted(pairs)


def _stops(fixed: int, layout: Layout) -> list[frozenset[int]]:
    """The fixed sensors a robot overlaps at each stop along its route."""
    if fixed <= 2:
        return [frozenset(range(fixed))]
    if layout == "ring":
        return [frozenset({s, (s + 1) % fixed}) for s in range(fixed)]
    return [frozenset({s, s + 1}) for s in range(fixed - 1)]


def _route(stops: int, layout: Layout, steps: int, start: int, forward: bool, stay: int) -> np.ndarray:
    """The stop index at each schedule step: round the ring, or along the row and back."""
    moves = np.arange(steps) // stay
    if layout == "ring" or stops == 1:
        return (start + (moves if forward else -moves)) % stops
    cycle = 2 * (stops - 1)  # there and back along the row
    pos = (start if forward else cycle - start) + moves
    pos %= cycle
    return np.where(pos < stops, pos, cycle - pos)


def passing(
    fixed: int,
    duration_s: float,
    layout: Layout = "ring",
    robots: int = 1,
    stay_s: float = 8.0,
    seed: int = 0,
) -> OverlapGraph:
    """Sensors ``0..robots-1`` ride robots past ``fixed`` fixed ones (the rest); one schedule step a second.

    The first robot starts at a random stop and drives forwards; a second one starts at the far end and
    drives backwards. Every sensor's frames count (``focus`` is None): what a robot costs the fixed
    sensors it passes is part of the measure.
    """
    if fixed < 0 or robots not in (1, 2):
        raise ConfigError(f"passing: fixed >= 0 and one or two robots, got fixed={fixed}, robots={robots}")
    if layout not in ("ring", "row"):
        raise ConfigError(f"passing: layout is 'ring' or 'row', got {layout!r}")
    if not (np.isfinite(stay_s) and stay_s >= 1) or not (np.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"passing: stay_s >= 1 and duration_s > 0, got {stay_s}, {duration_s}")
    rng = np.random.default_rng(seed)
    steps = int(np.ceil(duration_s))
    stay = round(stay_s)
    stops = _stops(fixed, layout)
    first = int(rng.integers(len(stops)))
    routes = [_route(len(stops), layout, steps, first, True, stay)]
    if robots == 2:
        routes.append(_route(len(stops), layout, steps, len(stops) - 1 - first, False, stay))
    pairs: list[tuple[int, int]] = [(robots + a, robots + b) for a, b in _fixed_pairs(fixed, layout)]
    rows = [np.ones(steps, dtype=bool)] * len(pairs)
    member = np.zeros((len(stops), fixed), dtype=bool)  # stop x fixed sensor: overlapped there
    for s, near in enumerate(stops):
        member[s, list(near)] = True
    for r, route in enumerate(routes):
        seen = member[route]  # schedule step x fixed sensor
        for j in np.flatnonzero(seen.any(axis=0)):
            pairs.append((r, robots + int(j)))
            rows.append(seen[:, j])
    if robots == 2:
        meet = (member[routes[0]] & member[routes[1]]).any(axis=1)  # beside a common fixed sensor
        if meet.any():
            pairs.append((0, 1))
            rows.append(meet)
    if not pairs:
        return OverlapGraph(robots + fixed, np.zeros(0, np.int64), np.zeros(0, np.int64))
    live = np.stack(rows)
    return OverlapGraph.from_pairs(robots + fixed, pairs, live=np.concatenate([live, live]), dt=1.0)


def passing_rooms(world: str, sensors: int, duration_s: float, rooms: int, seed: int = 0) -> OverlapGraph:
    """``rooms`` independent rooms of one passing world with ``sensors`` sensors in each (robots included:
    one, or two crossing), side by side in one graph; room r is seeded from ``seed`` and r."""
    if world not in WORLDS:
        raise ConfigError(f"passing world must be one of {', '.join(WORLDS)}, got {world!r}")
    robots = min(sensors, 2 if world == "crossing" else 1)
    layout: Layout = "ring" if world == "ring" else "row"
    return OverlapGraph.disjoint(
        [passing(sensors - robots, duration_s, layout, robots, seed=seed * 7919 + r) for r in range(rooms)]
    )
