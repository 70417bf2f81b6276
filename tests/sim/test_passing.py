import itertools

import numpy as np
import pytest

from d2sr.errors import ConfigError
from d2sr.sim.passing import passing, passing_rooms


def _live(g, a, b):
    """The schedule of the edge a -> b."""
    (i,) = np.flatnonzero((g.src == a) & (g.dst == b))
    return g.live[i]


def test_a_robot_passing_a_ring_meets_two_neighbours_at_a_time_and_moves_on_every_stay():
    g = passing(4, 40, "ring", seed=3, stay_s=8)
    fixed = {(a, b) for a, b in g.union_pairs().tolist() if a > 0}
    assert fixed == {(1, 2), (2, 3), (3, 4), (1, 4)}  # each fixed sensor overlaps its two ring neighbours
    assert all(_live(g, a, b).all() for a, b in fixed)
    seen = np.stack([_live(g, 0, j) for j in range(1, 5)])  # fixed sensors x seconds
    assert (seen.sum(0) == 2).all()  # two at a time
    for t in range(40):  # the pair is two ring neighbours, and changes only every 8 s
        a, b = np.flatnonzero(seen[:, t])
        assert (b - a) in (1, 3)
        if t % 8:
            assert (seen[:, t] == seen[:, t - 1]).all()
    assert len({tuple(seen[:, t]) for t in range(0, 40, 8)}) == 4  # it goes round all four pairs
    assert g.focus is None  # every sensor's frames count


def test_a_robot_passing_a_row_goes_along_and_back_and_two_robots_meet_when_they_share_a_sensor():
    g = passing(4, 48, "row", seed=0, stay_s=4)
    assert {(a, b) for a, b in g.union_pairs().tolist() if a > 0} == {(1, 2), (2, 3), (3, 4)}
    stops = [tuple(np.flatnonzero([_live(g, 0, j)[t] for j in range(1, 5)])) for t in range(0, 48, 4)]
    assert set(stops) == {(0, 1), (1, 2), (2, 3)}
    assert all(abs(a[0] - b[0]) == 1 for a, b in itertools.pairwise(stops))  # one stop at a time
    two = passing(4, 48, "row", robots=2, seed=0, stay_s=4)
    r0 = np.stack([_live(two, 0, 2 + j) for j in range(4)])
    r1 = np.stack([_live(two, 1, 2 + j) for j in range(4)])
    assert np.array_equal(_live(two, 0, 1), (r0 & r1).any(0))
    assert _live(two, 0, 1).any() and not _live(two, 0, 1).all()  # they cross, then part


def test_passing_rooms_are_independent_and_small_rooms_are_allowed():
    g = passing_rooms("crossing", 5, 30, rooms=3, seed=1)
    assert g.n == 15 and (g.src // 5 == g.dst // 5).all()
    assert passing_rooms("ring", 1, 10, rooms=2).src.size == 0  # a robot alone
    assert passing_rooms("row", 2, 10, rooms=1).union_pairs().tolist() == [[0, 1]]
    first, again = passing_rooms("ring", 5, 30, 2, seed=4), passing_rooms("ring", 5, 30, 2, seed=4)
    assert np.array_equal(first.live, again.live)


@pytest.mark.parametrize(
    "kw",
    [
        {"fixed": -1},
        {"robots": 3},
        {"layout": "star"},
        {"stay_s": 0.5},
        {"stay_s": float("nan")},
        {"duration_s": 0},
    ],
)
def test_passing_refuses_what_it_cannot_build(kw):
    args = {"fixed": 3, "duration_s": 10.0} | kw
    with pytest.raises(ConfigError):
        passing(**args)
    with pytest.raises(ConfigError):
        passing_rooms("maze", 3, 10, 1)
