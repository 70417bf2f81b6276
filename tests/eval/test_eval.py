import math

import numpy as np
import pytest

from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.eval.desync import Cell, check_bars, convergence_periods, has_slack, run_cell


def test_convergence_definition():
    r = np.zeros((3, 20))
    r[1, :7] = 0.5  # bad for 7 periods, then clean
    r[2, :] = 0.5  # never clean
    conv = convergence_periods(r)
    assert conv[0] == 0 and conv[1] == 7 and math.isinf(conv[2])


def test_slack_condition():
    assert has_slack(3, 6) and has_slack(2, 10)
    assert not has_slack(2, 15) and not has_slack(4, 6)


def test_run_cell_paired_and_sane():
    a = run_cell(Cell("stationary", 6, 3, "static", replicas=4, duration_s=10))
    b = run_cell(Cell("stationary", 6, 3, "oracle", replicas=4, duration_s=10))
    assert a.slack and b.steady == 0.0 and a.whole > 0.2
    m = run_cell(Cell("moving", 10, 3, "damped", replicas=3, duration_s=10))
    assert 0.0 <= m.whole <= 1.0 and len(m.converged) == 3


def test_bars_flag_a_failure():
    good = run_cell(Cell("stationary", 6, 2, "oracle", replicas=3, duration_s=10))
    from dataclasses import replace

    bad_default = replace(good, controller=DEFAULT_CONTROLLER, steady=0.3, whole=0.4)
    d2sr = replace(good, controller="d2sr", whole=0.2)
    checks = check_bars([good, bad_default, d2sr])
    failed = {c["bar"] for c in checks if not c["ok"]}
    assert "slack: steady <= 5%" in failed and "whole < d2sr where d2sr > oracle" in failed


def test_a_robot_passing_a_ring_counts_every_sensor_and_the_controllers_beat_static_there():
    from d2sr.eval.desync import simulate_cell, summarize

    cell = Cell("ring", 6, 5, "static", replicas=3, duration_s=20)
    cfg, graph, run = simulate_cell(cell)
    result, ratios = summarize(cell, cfg, graph, run)
    assert graph.n == 15 and graph.focus is None
    assert result.whole == pytest.approx(run.interfered.sum() / run.captured.sum(), abs=0.02)
    ours = run_cell(Cell("ring", 6, 5, DEFAULT_CONTROLLER, replicas=3, duration_s=20))
    assert ours.whole < result.whole  # paired seeds: the same rooms, phases and luck
    assert ratios.shape == (3, run.periods)


def test_fig9_draws_the_passing_ring_as_its_own_row_after_the_papers_two():
    from d2sr.eval.plots import fig9

    rows = [
        run_cell(Cell(sc, 6, 3, c, replicas=2, duration_s=6))
        for sc in ("ring", "moving", "stationary")
        for c in ("d2sr", DEFAULT_CONTROLLER)
    ]
    fig = fig9(rows, DEFAULT_CONTROLLER)
    titles = [ax.get_title() for ax in fig.axes]
    assert len(titles) == 6
    assert titles[0].startswith("stationary") and titles[2].startswith("moving")
    assert titles[4].startswith("a robot passing a ring")
