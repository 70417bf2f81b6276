"""The CW-ToF training source: made once beside its generated set, each kept frame interfered where its mask
says, and a frame's label in a batch follows its mask."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.errors import InputError
from d2sr.train.config import TrainSettings
from d2sr.train.cwtof import MIN_MOVED, cw_tof_frames, moved
from d2sr.train.data import Pool, synth_set


@pytest.mark.slow  # generates frames
def test_cw_tof_frames_are_made_once_and_each_kept_one_is_interfered(tmp_path):
    ss = synth_set(tmp_path, 4, 0, progress=False, previous=True)
    frames, used = cw_tof_frames(ss, 4)
    made = sorted(tmp_path.glob("*-cwtof-v*"))
    assert len(made) == 1
    stamp = (made[0] / "frames.npy").stat().st_mtime_ns
    again, used_again = cw_tof_frames(ss, 4)
    assert (made[0] / "frames.npy").stat().st_mtime_ns == stamp  # kept, not made again
    np.testing.assert_array_equal(np.asarray(again), np.asarray(frames))
    assert used.tolist() == used_again.tolist() and used.any()
    for i in np.flatnonzero(used):
        assert moved(frames[i], ss.clean[i], float(ss.scales[i])).sum() > MIN_MOVED
        assert not np.asarray(frames[i])[np.asarray(ss.clean[i]) == 0].any()  # no return stays none
    with pytest.raises(InputError):
        cw_tof_frames(ss, 5)

    cfg = TrainSettings.make(
        task="detector", model="detector-temporal", steps=2, batch=2, synthetic=4, cw_tof=4, cache=tmp_path
    )
    pool = Pool.from_config(cfg, progress=False, frames=2)
    src = pool.sources[1]
    assert src.labels.tolist() == used.tolist() and src.masks is not None
    b = pool.batch(np.random.default_rng(0), 16, None, clean_share=0.0)
    assert b.x.shape[1] == 2 and b.label.sum() > 0
    # Every label is 1 here: all frames drawn are interfered ones, whole (no crop).
    assert b.label.min() == 1.0
