"""Small graph helpers shared by the timing world and the oracle (numpy only)."""

from __future__ import annotations

import numpy as np

__all__ = ["components", "greedy_colouring"]


def greedy_colouring(n: int, pairs: np.ndarray) -> np.ndarray:
    """Colour classes of an undirected graph, highest degree first (sensors of a class may share time)."""
    neighbours: list[set[int]] = [set() for _ in range(n)]
    for a, b in pairs:
        neighbours[int(a)].add(int(b))
        neighbours[int(b)].add(int(a))
    colour = np.full(n, -1, dtype=np.int64)
    for v in sorted(range(n), key=lambda v: (-len(neighbours[v]), v)):
        used = {int(colour[u]) for u in neighbours[v] if colour[u] >= 0}
        colour[v] = next(c for c in range(n) if c not in used)
    return colour


def components(n: int, pairs: np.ndarray) -> np.ndarray:
    """Connected component label (its smallest member) of each of n nodes, union-find."""
    parent = list(range(n))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(x) for x in range(n)], dtype=np.int64)
