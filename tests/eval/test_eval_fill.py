import numpy as np

from d2sr.eval.fill import METHODS, PooledError, fig11, moving_robot_fill
from d2sr.eval.paper import _fig11_lines


def test_pool_pools_the_error_over_pixels_both_frames_have_and_counts_coverage_of_the_true_frame():
    p = PooledError()
    true = np.array([[1.0, 2.0], [0.0, 4.0]])
    p.add(np.array([[1.1, 0.0], [3.0, 4.0]]), true)  # one pixel missed, one invented where true has none
    assert p.coverage() == round(2 / 3, 4)
    assert p.rmse_cm() == round(100 * np.sqrt(0.01 / 2), 2)


def test_the_moving_robot_fill_gives_rmse_and_coverage_per_method_and_gap_and_fig11_draws_both():
    res = moving_robot_fill(rooms=1, seconds=1.0, kept=(20,))
    (run,) = res["runs"]
    assert run["active_frames"] == 20
    for m in METHODS:
        assert 0 <= run[f"{m}_coverage"] <= 1 and run[f"{m}_rmse_cm"] >= 0
        assert sorted(run["coverage_by_frames_since_real"][m], key=int) == list(range(1, 11))
    assert run["warp-pose_rmse_cm"] < run["hold_rmse_cm"]  # the robot moves: holding is wrong
    fig = fig11(res)
    left, right = fig.axes
    assert left.get_ylabel() == "RMSE (cm)" and right.get_ylabel().startswith("coverage")
    assert len(right.get_lines()) == len(METHODS)
    lines = _fig11_lines(res)
    assert lines[0].startswith("## Fig. 11") and any(line.startswith("| 20 |") for line in lines)
    assert _fig11_lines(None) == []
