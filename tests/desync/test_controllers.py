import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER, make_controller
from d2sr.errors import ConfigError

NAMES = sorted(CONTROLLERS)


def test_registry_and_default():
    assert {"static", "d2sr", "oracle"} <= set(CONTROLLERS)
    assert DEFAULT_CONTROLLER in CONTROLLERS
    assert DEFAULT_CONTROLLER not in ("static", "d2sr", "oracle")


def test_unknown_name_lists_the_choices():
    with pytest.raises(ConfigError) as err:
        make_controller("nope")
    for name in NAMES:
        assert name in str(err.value)


@pytest.mark.parametrize("n", [0, -1, 31])
def test_window_out_of_range(n):
    with pytest.raises(ConfigError, match="active_frames"):
        make_controller("d2sr", total_frames=30, active_frames=n)


@pytest.mark.parametrize("bad", [2.5, "x", None])
def test_window_wrong_type(bad):
    with pytest.raises(ConfigError):
        make_controller("d2sr", total_frames=30, active_frames=bad)


@pytest.mark.parametrize("name", NAMES)
def test_wrong_number_of_flags(name):
    c = make_controller(name, 30, 6)
    with pytest.raises(ConfigError, match="6 detections"):
        c.update([False] * 5)
    with pytest.raises(ConfigError, match="booleans"):
        c.update([0.5] * 6)


def test_initial_offset_checked():
    assert make_controller("static", 30, 6, offset=29).offset == 29
    with pytest.raises(ConfigError, match="offset"):
        make_controller("static", 30, 6, offset=30)


def test_unknown_option_is_a_config_error():
    with pytest.raises(ConfigError, match="damped"):
        make_controller("damped", 30, 6, wobble=3)
    with pytest.raises(ConfigError, match="escape"):
        make_controller("damped", 30, 6, escape=1.5)


def _overlap_flags(own: int, other: int, n: int, total: int = 30) -> list[bool]:
    """Which of our n frames (window order) fall in the other window, periods aligned, no start-up."""
    theirs = {(other + q) % total for q in range(n)}
    return [((own + q) % total) in theirs for q in range(n)]


def test_paper_fig5_example():
    """Fig. 5: n = 12, L1 hit in its second half moves back 4, L2 hit in its first half moves forward 4."""
    l1 = make_controller("d2sr", 30, 12, offset=0)
    l2 = make_controller("d2sr", 30, 12, offset=8)
    f1, f2 = _overlap_flags(0, 8, 12), _overlap_flags(8, 0, 12)
    assert sum(f1) == 4 and sum(f2) == 4  # 8 interfered frames between them
    assert l1.update(f1) == 26  # back by 4, wrapping
    assert l2.update(f2) == 12  # forward by 4
    assert not any(_overlap_flags(26, 12, 12)) and not any(_overlap_flags(12, 26, 12))
    assert l1.update([False] * 12) == 26 and l2.update([False] * 12) == 12  # de-conflicted: stay


def test_paper_odd_window_ignores_middle_frame():
    c = make_controller("d2sr", 30, 5, offset=10)
    assert c.update([False, False, True, False, False]) == 10
    assert c.update([True, True, True, False, False]) == 12
    assert c.update([False, False, True, True, True]) == 10


@given(st.sampled_from(NAMES), st.integers(1, 30), st.integers(0, 2**16), st.data())
def test_offsets_always_in_range(name, n, seed, data):
    c = make_controller(name, 30, n, seed=seed)
    assert 0 <= c.offset < 30
    for _ in range(data.draw(st.integers(1, 20))):
        flags = data.draw(st.lists(st.booleans(), min_size=n, max_size=n))
        new = c.update(flags)
        assert new == c.offset and 0 <= new < 30


@given(st.integers(1, 30), st.integers(0, 2**16), st.lists(st.booleans(), min_size=30, max_size=30))
def test_static_never_moves(n, seed, pattern):
    c = make_controller("static", 30, n, seed=seed)
    start = c.offset
    for k in range(10):
        c.update(pattern[k % 3 : k % 3 + n] if k % 3 + n <= 30 else pattern[:n])
        assert c.offset == start


@given(st.sampled_from(NAMES), st.integers(1, 30), st.integers(0, 2**16))
def test_same_seed_same_run(name, n, seed):
    rng = np.random.default_rng(seed)
    flags = rng.random((15, n)) < 0.4
    a, b = make_controller(name, 30, n, seed=seed), make_controller(name, 30, n, seed=seed)
    assert [a.update(f) for f in flags] == [b.update(f) for f in flags]


def test_damped_stays_when_clean_or_single_middle_flag():
    c = make_controller("damped", 30, 10, offset=5)
    assert c.update([False] * 10) == 5
    assert c.update([False] * 4 + [True] + [False] * 5) == 5


def test_damped_balanced_squeeze_is_steady():
    c = make_controller("damped", 30, 10, offset=5)
    assert c.update([True, True] + [False] * 6 + [True, True]) == 5


def test_damped_escapes_full_overlap_at_random():
    moved = [make_controller("damped", 30, 10, seed=s, offset=0).update([True] * 10) != 0 for s in range(200)]
    assert 0.35 < np.mean(moved) < 0.65  # escape probability 1/2: one of two twins usually leaves
    jumps = {make_controller("damped", 30, 10, seed=s, offset=0).update([True] * 10) for s in range(200)}
    assert jumps - {0} <= set(range(10, 21))  # a jump clears our own window and lands short of wrapping back


def test_damped_halves_a_reversal():
    c = make_controller("damped", 30, 12, offset=10)
    assert c.update([True] * 4 + [False] * 8) == 14  # pushed later by 4
    assert c.update([False] * 8 + [True] * 4) == 12  # reversal: -4 halved to -2
    # Algorithm 1 would bounce the full 4
    p = make_controller("d2sr", 30, 12, offset=10)
    p.update([True] * 4 + [False] * 8)
    assert p.update([False] * 8 + [True] * 4) == 10


def test_oracle_standalone_does_not_move():
    c = make_controller("oracle", 30, 6, offset=3)
    assert c.update([True] * 6) == 3
    c.assign(37)
    assert c.offset == 7


def test_damped_freezes_when_the_period_is_saturated():
    c = make_controller("damped", 30, 10, offset=5)
    squeezed = [True] * 3 + [False] + [True] * 6  # head 4, tail 5: pushes 1 earlier when not congested
    assert c.update(squeezed) == 4 and c.load < 0.75
    for _ in range(12):  # nine of ten frames hit, period after period
        c.update([True] * 9 + [False])
    assert c.load > 0.75
    before = c.offset
    assert c.update(squeezed) == before  # saturated and squeezed: stays


@given(st.lists(st.booleans(), min_size=10, max_size=10), st.integers(0, 29))
def test_robust_is_algorithm_1_unless_its_window_is_covered(flags, offset):
    paper = make_controller("d2sr", 30, 10, offset=offset)
    robust = make_controller("robust", 30, 10, seed=1, offset=offset)
    if sum(flags) < 9 or sum(flags[:5]) != sum(flags[5:]):
        assert robust.update(flags) == paper.update(flags)


def test_robust_escapes_a_lasting_stall_at_random_and_backs_off_in_a_crowd():
    def stalled(seed: int) -> int:
        c = make_controller("robust", 30, 10, seed=seed, offset=0)
        assert c.update([True] * 10) == 0  # covered once: maybe a crowd passing, wait
        return c.update([True] * 10)

    moved = [stalled(s) != 0 for s in range(400)]
    assert 0.4 < np.mean(moved) < 0.6  # covered twice: of two identical sensors, one usually leaves
    jumps = {stalled(s) for s in range(400)} - {0}
    assert min(jumps) >= 10 and max(jumps) <= 20  # at least a window, at most the period minus one
    # covered wherever it goes (a saturated period): each failed escape halves the chance of the next
    tries = []
    for s in range(300):
        c = make_controller("robust", 30, 10, seed=s, offset=0)
        escapes = 0
        for _ in range(40):
            before = c.offset
            escapes += c.update([True] * 10) != before
        tries.append(escapes)
    assert np.mean(tries) < 5  # about log2 of the periods; without backoff, 10 of 40
