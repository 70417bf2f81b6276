"""The CW-ToF interference generator: its unwrapping reads clean phases back exactly, small phasors move
depth as the phase error says, strong or cancelling ones are rejected, a frame keeps what had no return."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from d2sr.errors import InputError
from d2sr.sim import cwtof
from d2sr.sim.cwtof import AZURE, KINECT2, C, cw_tof_interference


def _wall(h: int = 96, w: int = 128, mm: int = 1500) -> np.ndarray:
    d = np.full((h, w), mm, np.uint16)
    d[:, : w // 5] = 0  # no return on the left
    return d


def test_the_unwrapping_reads_clean_phases_back_at_any_depth_in_its_range():
    d = np.array([0.3, 1.2, 2.5, 4.9, 9.4, 17.0])
    for cam in (KINECT2, AZURE):
        inside = d[d < cam.unwrap_m]
        out = cwtof._unwrap(inside, np.zeros((len(cam.frequencies_hz), inside.size), np.complex64), cam)
        np.testing.assert_allclose(out, inside, atol=1e-6)
    # Beyond the range a depth reads as its wrap (18.74 m for the Kinect v2's 8 MHz common divisor).
    beyond = cwtof._unwrap(np.array([KINECT2.unwrap_m + 1.0]), np.zeros((3, 1), np.complex64), KINECT2)
    assert beyond[0] == pytest.approx(1.0, abs=1e-6)


def test_a_small_phasor_moves_depth_by_the_weighted_phase_errors():
    d = np.array([2.0])
    f = np.asarray(KINECT2.frequencies_hz, float)
    z = np.array([[0.05j], [0.05j], [0.05j]], np.complex64)  # +0.05 rad at every frequency
    out = cwtof._unwrap(d, z, KINECT2)
    eps = np.angle(1 + 0.05j)
    w = f**2 * abs(1 + 0.05j) ** 2
    want = 2.0 + np.sum(w * eps * C / (4 * np.pi * f)) / np.sum(w)
    assert out[0] == pytest.approx(want, abs=1e-6)
    assert out[0] > 2.0  # a phase that lags reads farther


def test_a_cancelled_or_disagreeing_return_is_rejected():
    d = np.array([2.0, 2.0])
    z = np.array([[-0.9, 0.0], [0.0, 0.0], [0.0, 0.0]], np.complex64)  # amplitude 0.1 at 80 MHz
    z[:, 1] = [np.exp(1j * 2.0), 0, 0]  # a phase pushed 1 rad at 80 MHz alone: the others disagree
    out = cwtof._unwrap(d, z, KINECT2)
    assert out[0] == 0 and out[1] == 0


def test_the_generator_is_a_pure_function_of_its_seed_and_keeps_no_return_as_none():
    d = _wall()
    a, ma = cw_tof_interference(d, 1000.0, 3)
    b, _ = cw_tof_interference(d, 1000.0, 3)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(ma, a != d)
    assert not a[d == 0].any()
    changed = [cw_tof_interference(d, 1000.0, s)[1].sum() for s in range(12)]
    assert max(changed) > 100  # some draws interfere with the wall


def test_bad_input_is_refused_with_d2srs_error():
    with pytest.raises(InputError):
        cw_tof_interference(np.ones((8, 8), np.float32), 1000.0, 0)
    with pytest.raises(InputError):
        cw_tof_interference(_wall(), 0.0, 0)


@settings(max_examples=25, deadline=None)
@given(arrays(np.uint16, (12, 16)), st.integers(0, 2**31), st.sampled_from([1000.0, 4000.0]))
def test_any_frame_gives_a_frame_of_its_shape_and_its_mask(depth, seed, scale):
    out, mask = cw_tof_interference(depth, scale, seed)
    assert out.shape == depth.shape and out.dtype == np.uint16
    np.testing.assert_array_equal(mask, out != depth)
    assert not out[depth == 0].any()
