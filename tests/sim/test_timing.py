import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from d2sr.desync import DEFAULT_CONTROLLER, make_controller
from d2sr.errors import ConfigError
from d2sr.sim import OverlapGraph, TimingSettings, simulate
from d2sr.sim.timing import Clocks

EXACT = {"recall": 1.0, "false_alarm": 0.0, "hit_prob": 1.0, "drift_ppm": 0.0}


@given(st.integers(1, 30), st.integers(0, 10_000), st.sampled_from(["static", "d2sr", "damped", "oracle"]))
def test_one_sensor_is_never_interfered(n, seed, name):
    run = simulate(
        OverlapGraph(1, [], []), name, TimingSettings(active_frames=n, false_alarm=0.2), 5, seed=seed
    )
    assert run.interfered.sum() == 0
    assert run.captured.sum() == 5 * n  # every window frame delivered, no drops by default


@given(st.integers(1, 30), st.integers(0, 29), st.integers(0, 3), st.integers(0, 10_000))
def test_identical_windows_full_overlap_every_frame_interfered(n, offset, setup, seed):
    cfg = TimingSettings.make(active_frames=n, setup=setup, **EXACT)
    ctrls = [make_controller("static", 30, n, offset=offset) for _ in range(2)]
    run = simulate(OverlapGraph.complete(2), ctrls, cfg, 4, seed=seed, clocks=Clocks(np.array([0.3, 0.3])))
    assert run.captured.sum() == 2 * 4 * n
    assert np.array_equal(run.interfered, run.captured)


def test_same_seed_same_run_and_seed_matters():
    g = OverlapGraph.complete(3).replicate(3)
    a, b = (simulate(g, "damped", TimingSettings(active_frames=6), 20, seed=5) for _ in range(2))
    c = simulate(g, "damped", TimingSettings(active_frames=6), 20, seed=6)
    assert np.array_equal(a.offsets, b.offsets) and np.array_equal(a.interfered, b.interfered)
    assert not np.array_equal(a.offsets, c.offsets)


def test_fig5_in_the_timing_world():
    """Two aligned sensors at n = 12, offsets 0 and 8: Algorithm 1 de-conflicts them after one period."""
    cfg = TimingSettings.make(active_frames=12, setup=0, **EXACT)
    ctrls = [make_controller("d2sr", 30, 12, offset=0), make_controller("d2sr", 30, 12, offset=8)]
    run = simulate(OverlapGraph.complete(2), ctrls, cfg, 10, clocks=Clocks(np.array([0.0, 0.0])))
    assert run.interfered[:, 0].tolist() == [4, 4]
    assert run.offsets[:, 1].tolist() == [26, 12]
    assert run.interfered[:, 1:].sum() == 0


@pytest.mark.parametrize(("sensors", "expected"), [(2, 0.50), (3, 0.75), (5, 0.94)])
def test_random_static_offsets_match_closed_form(sensors, expected):
    """DESIGN.md: half duty cycle, full overlap, random static offsets -> 50%, 75%, 94% interfered."""
    cfg = TimingSettings.make(active_frames=15, setup=0, hit_prob=1.0)
    run = simulate(OverlapGraph.complete(sensors).replicate(100), "static", cfg, 5, seed=1)
    assert abs(run.ratio() - expected) < 0.04


def test_setup_slots_interfere_but_deliver_nothing():
    # B's window starts right after A's; B's start-up slots (3, 4) sit on A's last frames.
    cfg = TimingSettings.make(active_frames=5, setup=2, **EXACT)
    a, b = make_controller("static", 30, 5, offset=0), make_controller("static", 30, 5, offset=5)
    run = simulate(OverlapGraph.complete(2), [a, b], cfg, 3, clocks=Clocks(np.zeros(2)))
    assert run.interfered[0].tolist() == [2, 2, 2]  # A's frames 3, 4 lie under B's start-up (slots 5, 6)
    assert run.interfered[1].sum() == 0  # B's frames 5..9 see no laser (A's start-up is at 28, 29)
    assert run.captured.sum() == 2 * 3 * 5


def test_detector_rates_and_drops():
    cfg = TimingSettings.make(active_frames=15, recall=0.7, false_alarm=0.05, drop=0.1)
    run = simulate(OverlapGraph.complete(2).replicate(50), "static", cfg, 20, seed=2)
    windows = 2 * 50 * 20 * 15
    assert abs(run.captured.sum() / windows - 0.9) < 0.01
    bad, cap = run.interfered.sum(), run.captured.sum()
    assert abs(run.true_detected.sum() / bad - 0.7) < 0.02
    assert abs((run.detected.sum() - run.true_detected.sum()) / (cap - bad) - 0.05) < 0.01


def test_common_random_numbers_across_controllers():
    """At n = 30 windows cover the whole period, so every controller must see exactly the same frames."""
    g = OverlapGraph.complete(3).replicate(4)
    runs = [
        simulate(g, name, TimingSettings(active_frames=30), 10, seed=3)
        for name in ("static", "d2sr", "damped")
    ]
    for r in runs[1:]:
        assert np.array_equal(r.interfered, runs[0].interfered)


def test_edges_switched_off_mean_no_interference():
    live = np.zeros((2, 10), dtype=bool)
    g = OverlapGraph(2, [0, 1], [1, 0], live=live)
    run = simulate(g, "static", TimingSettings(active_frames=30, hit_prob=1.0), 10)
    assert run.interfered.sum() == 0
    live[:, 5:] = True  # overlap from the 5th second on
    run = simulate(OverlapGraph(2, [0, 1], [1, 0], live=live), "static", TimingSettings(active_frames=30), 10)
    assert run.interfered[:, :4].sum() == 0 and run.interfered[:, 6:].sum() > 0


def test_absent_sensor_captures_nothing_and_harms_nobody():
    present = np.ones((2, 10), dtype=bool)
    present[1, :] = False
    g = OverlapGraph(2, [0, 1], [1, 0], present=present)
    run = simulate(g, "static", TimingSettings(active_frames=30, hit_prob=1.0), 10)
    assert run.captured[1].sum() == 0 and run.interfered.sum() == 0 and run.captured[0].sum() == 300


@pytest.mark.slow  # a long simulation: not in make test-fast
def test_drift_moves_windows_apart_over_time():
    """Two static sensors 400 ppm apart slide 0.4 ms per period against each other: 0.24 s in 600 s."""
    cfg = TimingSettings.make(active_frames=3, setup=0, **EXACT)
    ctrls = [make_controller("static", 30, 3, offset=0) for _ in range(2)]
    run = simulate(
        OverlapGraph.complete(2), ctrls, cfg, 600, clocks=Clocks(np.zeros(2), np.array([2e-4, -2e-4]))
    )
    assert run.interfered[:, :10].sum() == 2 * 10 * 3  # aligned at first
    assert run.interfered[:, -10:].sum() == 0  # 7 slots apart by the end


def test_oracle_time_shares_perfectly_with_slack():
    run = simulate(
        OverlapGraph.complete(3).replicate(5), "oracle", TimingSettings(active_frames=6), 30, seed=4
    )
    assert run.ratio(start=5) == 0.0


def test_default_controller_converges_with_slack():
    run = simulate(
        OverlapGraph.complete(3).replicate(10),
        DEFAULT_CONTROLLER,
        TimingSettings(active_frames=6),
        40,
        seed=4,
    )
    assert run.ratio(start=20) <= 0.05


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("recall", 1.5, "recall"),
        ("false_alarm", -0.1, "false_alarm"),
        ("hit_prob", 2.0, "hit_prob"),
        ("drop", -1.0, "drop"),
        ("drift_ppm", -5.0, "drift_ppm"),
        ("fps", -30.0, "fps"),
        ("active_frames", 31, "active_frames"),
        ("active_frames", 0, "active_frames"),
    ],
)
def test_bad_settings_are_one_line_errors(field, value, message):
    with pytest.raises(ConfigError, match=message) as err:
        TimingSettings.make(**{field: value})
    assert "\n" not in str(err.value)


def test_bad_run_arguments():
    g = OverlapGraph.complete(2)
    with pytest.raises(ConfigError, match="duration"):
        simulate(g, "static", duration_s=0)
    with pytest.raises(ConfigError, match="2 sensors"):
        simulate(g, [make_controller("static")], duration_s=2)
    with pytest.raises(ConfigError, match="unknown controller"):
        simulate(g, "nope", duration_s=2)
    with pytest.raises(ConfigError, match="phases"):
        simulate(g, "static", duration_s=2, clocks=Clocks(np.zeros(3)))


def test_disjoint_keeps_presence_schedules_longer_than_the_live_ones():
    present = np.ones((2, 30), bool)
    present[1, :10] = False  # sensor 1 joins after 10 s
    g = OverlapGraph.complete(2)
    one = OverlapGraph(2, g.src, g.dst, present=present)
    both = OverlapGraph.disjoint([one, OverlapGraph.complete(3)])
    assert both.present is not None and both.present.shape == (5, 30)
    assert not both.present[1, :10].any() and both.present[2:].all()
