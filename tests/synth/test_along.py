import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from d2sr.errors import InputError
from d2sr.synth import Filler
from d2sr.synth.along import STEPS, fill_along_colour


def _scene():
    """A 160x120 colour frame: a red left half, a blue right half; depth measured in the left quarter."""
    colour = np.zeros((120, 160, 3), np.uint8)
    colour[:, :80] = (40, 40, 200)
    colour[:, 80:] = (200, 60, 30)
    depth = np.zeros((120, 160), np.float32)
    depth[:, :40] = 2.0
    return depth, (depth > 0).astype(np.float32), colour


def test_depth_spreads_along_its_colour_region_and_stops_at_a_colour_edge():
    depth, conf, colour = _scene()
    out, c = fill_along_colour(depth, conf, colour)
    assert (out[:, 40:80] == 2.0).all()  # the rest of the red region, from the measured pixels in it
    assert (c[:, 40:80] == STEPS[0][1]).all()  # at the tight pass's confidence
    assert (out[:, 88:] == 0).all() and (c[:, 88:] == 0).all()  # the blue region is another surface
    assert np.array_equal(out[:, :40], depth[:, :40]) and (c[:, :40] == 1).all()  # measured: as it was


def test_the_loose_pass_reaches_across_a_gentle_colour_step_at_a_lower_confidence():
    depth, conf, colour = _scene()
    colour[:, 80:] = (40, 40, 200)
    colour[:, 80:] += np.array([0, 0, 16], np.uint8)  # a shade of the same red: beyond sigma 4, within 7
    out, c = fill_along_colour(depth, conf, colour)
    assert (out[:, 88:] == 2.0).all()
    assert np.allclose(c[:, 88:], STEPS[1][1])  # only the loose pass crossed the step
    assert np.allclose(c[:, 40:80], STEPS[0][1])


def test_a_frame_without_holes_or_without_any_depth_comes_back_as_it_was():
    depth, _, colour = _scene()
    full = np.full_like(depth, 3.0)
    out, c = fill_along_colour(full, np.ones_like(full), colour)
    assert np.array_equal(out, full) and (c == 1).all()
    empty = np.zeros_like(depth)
    out, c = fill_along_colour(empty, np.zeros_like(empty), colour)
    assert not out.any() and not c.any()


def test_the_filler_states_what_it_carried_along_the_colour_and_leaves_real_frames_alone():
    depth, _, colour = _scene()
    f = Filler()
    real = f.real(depth, colour)
    assert np.array_equal(real.depth, depth)
    s = f.synthesize(colour)
    carried = (depth == 0) & (s.depth > 0)
    assert carried.any()
    assert (s.confidence[carried] < 1).all() and (s.confidence[s.depth == 0] == 0).all()
    beyond = carried.copy()
    beyond[:, :60] = False  # past the background fill's reach (8 px at this width): carried along the colour
    assert beyond.any() and np.allclose(s.confidence[beyond], STEPS[0][1])


@pytest.mark.parametrize(
    ("colour", "said"),
    [
        (np.zeros((120, 160, 2), np.uint8), "channels"),
        (np.zeros((120, 160, 3), np.int8), "8- or 16-bit"),
        (np.zeros((100, 160, 3), np.uint8), "differ in size"),
        (np.zeros((120, 160, 3, 1), np.uint8), "image array"),
    ],
)
def test_a_colour_frame_the_filler_cannot_read_is_one_input_error_on_either_call(colour, said):
    depth, _, good = _scene()
    with pytest.raises(InputError, match=said):
        Filler().real(depth, colour)
    f = Filler()
    f.real(depth, good)
    with pytest.raises(InputError, match=said):
        f.synthesize(colour)


def test_sixteen_bit_float_and_four_channel_colour_frames_are_read_as_eight_bit():
    depth, _, colour = _scene()
    as8 = Filler()
    as8.real(depth, colour)
    want = as8.synthesize(colour).depth
    alpha = np.full((120, 160, 1), 255, np.uint8)
    for other in (colour.astype(np.uint16) * 257, colour / 255.0, np.concatenate([colour, alpha], axis=2)):
        f = Filler()
        f.real(depth, other)
        assert np.array_equal(f.synthesize(other).depth, want)


_DTYPES = st.sampled_from(["u1", "u2", "i1", "i4", "f4", "f8", "?", "c8"])
_SHAPES = st.sampled_from(
    [(12, 16), (12, 16, 1), (12, 16, 2), (12, 16, 3), (12, 16, 4), (10, 16, 3), (12,), ()]
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_DTYPES, _SHAPES, _DTYPES, _SHAPES, st.integers(0, 2**32 - 1))
def test_the_filler_takes_any_array_for_depth_and_colour_or_says_why(dd, ds, cd, cs, seed):
    rng = np.random.default_rng(seed)

    def array(dtype, shape):
        a = rng.uniform(-1, 300, shape) if shape else np.float64(rng.uniform(0, 9))
        return np.asarray(a).astype(dtype)

    depth, colour = array(dd, ds), array(cd, cs)
    f = Filler()
    try:
        f.real(depth, colour)
        s = f.synthesize(colour)
    except InputError:
        return
    assert s.depth.shape == depth.shape[:2] and np.isfinite(s.depth).all()
    assert ((s.confidence >= 0) & (s.confidence <= 1)).all()
