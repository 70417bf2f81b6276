"""Recovery metrics on a hand-made test set whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.eval import models as em
from d2sr.eval.models import operating_curve, recovery_metrics


def _set() -> em.TestSet:
    rng = np.random.default_rng(0)
    clean = [(rng.uniform(1, 4, (32, 48)) * 1000).astype(np.uint16) for _ in range(3)]
    frames = []
    for c in clean:
        f = c.copy()
        f[8:16, :] //= 4  # a band read far too near (holes alone are no sign: contract.repair)
        frames.append(f)
    return em.TestSet("toy", frames, clean, 1000.0, np.zeros(3, bool))


def _raw(x: np.ndarray, prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Confident on the band (logit 5), unsure of a stripe of clean pixels (logit 0), sure elsewhere;
    depth: 2 m on the band, 50 cm off the input elsewhere (beyond the do-no-harm tolerance)."""
    logit = np.full(x.shape, -5.0, np.float32)
    logit[8:16] = 5
    logit[20:24] = 0
    return logit, np.where(logit > 4, 2.0, x + 0.5).astype(np.float32)


def test_operating_curve_walks_from_identity_to_all_repaired():
    ts = _set()
    c = operating_curve(ts, _raw, [6.0, 1.0, -1.0, -6.0])
    assert c["rmse_vs_identity"][0] == 0 and c["clean_changed"][0] == 0  # nothing masked
    # the band repaired, nothing else touched
    assert c["rmse_vs_identity"][1] < -0.3 and c["clean_changed"][1] == 0
    n_clean = 32 * 48 - 8 * 48
    # the unsure stripe (a few pixels whose clamp to the neighbours' range lands within 1 cm stay)
    assert 0.9 * 4 * 48 / n_clean <= c["clean_changed"][2] <= 4 * 48 / n_clean + 1e-4
    assert np.isclose(c["clean_changed"][3], 1.0)
    assert c["rmse_vs_identity"][3] > c["rmse_vs_identity"][1]  # repairing clean pixels costs RMSE


def test_recovery_metrics_identity_and_true_mask_ceiling():
    ts = _set()

    def model(x: np.ndarray, prev: np.ndarray | None, scale: float) -> tuple[np.ndarray, np.ndarray]:
        logit, pred = _raw(x, prev)
        return np.where(logit > 1, pred, x), logit > 1

    rows, _ = recovery_metrics(ts, {"m": model}, "m")
    assert rows["identity"]["rmse_vs_identity"] == 0 and rows["identity"]["mask_f1"] == 0
    assert rows["m"]["mask_f1"] == 1 and rows["m"]["clean_changed"] == 0
    # nearest infill from the band's edges (the toy's depths are independent draws): about -0.39
    assert rows["nearest (true mask)"]["rmse_vs_identity"] < -0.3
    assert rows["median (predicted mask)"]["mask_f1"] == 1


def test_a_real_folder_without_the_captures_is_said_not_skipped_silently(tmp_path, monkeypatch):
    # `--real ../shared/data` (the parent) once dropped the real L515 set from the figures without a word.
    from d2sr import ui
    from d2sr.eval.learned import _real_sets

    monkeypatch.setattr(ui, "_pending", [])
    assert _real_sets(tmp_path) == []
    assert len(ui._pending) == 1 and "no dev0/ capture here" in ui._pending[0]


def test_one_sequence_of_a_set_keeps_its_frames_and_its_last_clean_frames():
    z = np.zeros((2, 2), np.uint16)
    hit = z + 1
    frames = [z, hit, z, hit, z, hit, hit]  # two sequences: 0-2 and 3-6
    labels = np.array([False, True, False, True, False, True, True])
    ts = em.TestSet("two", frames, [z] * 7, 1000.0, np.zeros(7, bool), starts=(0, 3))
    ts.last_clean = em._last_clean(labels, [0, 3])
    second = ts.sequence(1, "second")
    assert second.name == "second" and len(second.frames) == 4 and second.starts == (0,)
    assert second.labels.tolist() == [True, False, True, True]
    assert second.last_clean is not None and second.last_clean.tolist() == [-1, -1, 1, 1]
    assert second.before(0) is None and np.array_equal(second.before(1), ts.metres(3))
    with pytest.raises(IndexError):
        ts.sequence(2, "none")
