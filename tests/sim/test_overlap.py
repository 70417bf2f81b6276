import numpy as np
import pytest

from d2sr.errors import ConfigError
from d2sr.graphs import components, greedy_colouring
from d2sr.sim.overlap import OverlapGraph, _pairs_within


def test_complete_graph_both_directions():
    g = OverlapGraph.complete(4)
    assert g.src.size == 12
    assert set(zip(g.src.tolist(), g.dst.tolist(), strict=True)) == {
        (a, b) for a in range(4) for b in range(4) if a != b
    }


def test_replicate_keeps_copies_apart():
    g = OverlapGraph.complete(3).replicate(4)
    assert g.n == 12 and g.src.size == 24
    assert np.array_equal(g.src // 3, g.dst // 3)
    assert components(g.n, g.union_pairs()).tolist() == [0, 0, 0, 3, 3, 3, 6, 6, 6, 9, 9, 9]


def test_moving_robot_schedule():
    g = OverlapGraph.moving_robot(4, 60, seed=1)
    assert g.focus.tolist() == [0]
    robot = (g.src == 0) | (g.dst == 0)
    assert g.live[~robot].all()  # fixed sensors always overlap each other
    seen = g.live[robot].mean()
    assert 0.3 < seen < 0.9  # the robot sees each fixed sensor for part of its loop
    d = OverlapGraph.disjoint([g, OverlapGraph.moving_robot(3, 30, seed=2)])
    assert d.n == 7 and d.focus.tolist() == [0, 4] and d.live.shape[1] == 60


def test_pairs_within_matches_brute_force():
    pos = np.random.default_rng(0).uniform(0, 20, (300, 2))
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2)
    a, b = np.nonzero(np.triu(d < 2.0, 1))
    got = _pairs_within(pos, 2.0)
    assert {tuple(p) for p in got.tolist()} == set(zip(a.tolist(), b.tolist(), strict=True))


def test_warehouse_has_a_few_neighbours_and_moving_robots():
    g = OverlapGraph.warehouse(400, 20, seed=0)
    degree = np.bincount(g.dst, minlength=g.n) * g.live.mean(axis=1).mean()
    assert 2.0 < degree.mean() < 6.0
    assert not g.live.all(axis=1).all()  # some overlaps come and go


def test_colouring_is_proper():
    pairs = np.array([[0, 1], [1, 2], [2, 0], [2, 3]])
    c = greedy_colouring(4, pairs)
    assert all(c[a] != c[b] for a, b in pairs)
    assert c.max() == 2


@pytest.mark.parametrize(
    "kwargs",
    [
        {"n": 2, "src": [0], "dst": [2]},
        {"n": 2, "src": [1], "dst": [1]},
        {"n": 0, "src": [], "dst": []},
        {"n": 2, "src": [0], "dst": [1], "live": np.ones((2, 3), dtype=bool)},
    ],
)
def test_bad_graphs(kwargs):
    with pytest.raises(ConfigError):
        OverlapGraph(**kwargs)
