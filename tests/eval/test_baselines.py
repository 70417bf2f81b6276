"""Classical baselines change only masked pixels and fill a hole in a smooth surface well."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.eval.baselines import BASELINES


def _plane() -> tuple[np.ndarray, np.ndarray]:
    y, x = np.mgrid[0:120, 0:160].astype(np.float32)
    d = 2.0 + 0.004 * x + 0.002 * y
    d[:, :20] = 0  # no return here
    mask = np.zeros(d.shape, bool)
    mask[50:70, 60:100] = True
    return d, mask


@pytest.mark.parametrize("name", list(BASELINES))
def test_only_masked_pixels_change_and_holes_fill(name):
    d, mask = _plane()
    broken = d.copy()
    broken[mask] = 0
    out = BASELINES[name](broken, mask)
    assert np.array_equal(out[~mask], broken[~mask])
    err = np.abs(out[mask] - d[mask])
    assert np.median(err) < 0.05, np.median(err)
    assert (out[mask] > 0).all()


def test_zeros_outside_the_mask_are_not_sources():
    d, mask = _plane()
    mask[:, 15:25] = False
    mask[40:80, 21:30] = True  # hole touching the no-return band
    out = BASELINES["nearest"](d, mask)
    assert (out[mask] > 1.9).all()
