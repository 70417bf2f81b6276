"""The outside sets (``bench.outside``, issue 82): the interference behind the README's outside rows is a
tested part of the benchmarks. Each set's draw is fixed by its seed and corrupts a real-looking frame; a
sequence keeps its clean frames as they were; the benchmark answers --help."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from bench.outside.draw import KINDS, SALTS, SEED
from bench.outside.sets import OWN, SEALED, SETS, STATUS, every_other, kind, open_sets, set_data

ROOT = Path(__file__).resolve().parents[2]


def _room(seed: int = 0) -> np.ndarray:
    """A 120x160 room at 4000 units per metre: a back wall, a box, a floor ramp and a few dropouts."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:120, 0:160]
    d = np.full((120, 160), 3.2) + 0.002 * x
    d[60:, :] = np.minimum(d[60:, :], 1.2 + 0.03 * (120 - y[60:, :]))
    d[30:70, 50:90] = 1.6
    frame = np.rint(d * 4000).astype(np.uint16)
    frame[rng.random(frame.shape) < 0.02] = 0
    return frame


def test_every_set_has_its_salt_its_two_models_and_a_status():
    assert set(SETS) == set(SALTS) == set(KINDS) == set(STATUS)
    assert len(set(SALTS.values())) == len(SALTS)  # no two sets share a stream of random numbers
    assert all(len(KINDS[s]) == 2 for s in SETS)


@pytest.mark.parametrize("which", sorted(SETS))
def test_a_set_corrupts_a_frame_the_same_way_for_the_same_seed(which):
    frame = _room()
    a, b = (SETS[which](frame.copy(), 4000.0, SEED + 1) for _ in range(2))
    assert a.dtype == np.uint16 and a.shape == frame.shape
    assert np.array_equal(a, b)  # the seed fixes the draw
    assert (a != frame).any()
    assert kind(which, SEED + 1) in KINDS[which]  # the model the seed's first draw picks


def test_every_other_frame_of_a_sequence_is_corrupted_and_the_others_are_the_clean_frames():
    clean = [_room(k) for k in range(6)]
    bad = every_other(clean, 4000.0, "a")
    for i, (b, c) in enumerate(zip(bad, clean, strict=True)):
        # a draw may leave a frame as it was (set A's regions can miss every return): the same draw
        assert (b is c) if i % 2 == 0 else np.array_equal(b, SETS["a"](c, 4000.0, SEED + i))
    assert any((b != c).any() for b, c in zip(bad[1::2], clean[1::2], strict=True))


def test_the_open_sets_are_the_readme_sets_a_to_i():
    assert open_sets() == list("abcdefghi")
    assert not (set(open_sets()) & (SEALED | OWN))
    for which in open_sets():
        assert set_data(which)["status"].startswith("development")  # every open set has chosen something


def test_the_benchmark_answers_help_as_a_package():
    cmd = [sys.executable, "-m", "bench.outside", "--help"]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
    assert done.returncode == 0 and "--set" in done.stdout
