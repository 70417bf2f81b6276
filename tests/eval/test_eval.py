import math

import numpy as np

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
