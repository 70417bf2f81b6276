"""The repair every backend shares (d2sr.contract.repair): the guard, the passes, the scene's part, and when a
temporal model's last clean frame lines up."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.contract.metrics import RepairSums
from d2sr.contract.repair import agreement, guard, recover_passes, repair_frame
from d2sr.errors import InputError
from d2sr.scene import SceneRepair


def test_agreement_counts_pixels_returning_in_both_within_5_cm_and_2_percent():
    a = np.full((4, 4), 2.0, np.float32)
    assert agreement(a, None) == 0.0
    assert agreement(a, a) == 1.0
    b = a.copy()
    b[0] = 2.0 + 0.05 + 0.02 * 2.0 + 0.01  # one row just outside the tolerance
    b[1] = 2.0 + 0.05 + 0.02 * 2.0 - 0.01  # one just inside
    b[2] = 0.0  # no return: not counted
    assert agreement(a, b) == pytest.approx(2 / 3)
    assert agreement(a, np.zeros_like(a)) == 0.0
    with pytest.raises(InputError):
        agreement(a, np.zeros((4, 5), np.float32))


def _wall() -> np.ndarray:
    return np.full((40, 48), 2.0, np.float32)


def test_the_guard_clamps_to_the_trusted_neighbours_and_leaves_what_the_model_cannot_tell():
    """A hit patch read a metre near, predicted a metre behind the wall: the prediction is clamped to the
    trusted returns around it (their range widened by 3 cm + 2% of its reading) and repairs the patch; a
    return the prediction would move by less than the model's own error is left; nothing outside the mask
    changes."""
    metres = _wall()
    mask = np.zeros(metres.shape, bool)
    mask[10:20, 10:20] = True
    metres[mask] = 1.0
    pred = np.full(metres.shape, 3.0, np.float32)
    p, keep = guard(metres, pred, mask)
    assert keep[mask].all() and not keep[~mask].any()
    assert np.allclose(
        p[mask], 2.0 + 0.03 + 0.02 * 1.0, atol=1e-6
    )  # the range, widened by the pixel's own noise
    wall = _wall()
    close = np.where(mask, wall + 0.05, wall).astype(np.float32)  # within 3 cm + 10% of 2 m
    _, keep_close = guard(wall, close, mask)
    assert not keep_close.any()


def test_a_lone_return_is_left_as_it_is():
    metres = np.zeros((40, 48), np.float32)
    metres[20, 20] = 2.0  # no surface around it says where it belongs
    mask = np.zeros(metres.shape, bool)
    mask[20, 20] = True
    _, keep = guard(metres, np.full(metres.shape, 1.0, np.float32), mask)
    assert not keep.any()


def test_repair_frame_changes_only_the_mask_and_takes_the_scene_where_it_knows():
    frame = np.full((40, 48), 8000, np.uint16)  # 2 m at 4000 units per metre
    frame[5:15, 5:15] = 6000  # read 50 cm near
    mask = np.zeros(frame.shape, bool)
    mask[5:15, 5:15] = True
    pred = np.full(frame.shape, 2.0, np.float32)
    out, repaired = repair_frame(frame, pred, mask, 4000.0)
    assert np.array_equal(out[~repaired], frame[~repaired]) and repaired[5:15, 5:15].all()
    assert out.dtype == np.uint16 and (out[5:15, 5:15] == 8000).all()
    # The scene keeps a pixel from the model, and fills one past the guard's margin.
    keep = np.zeros(frame.shape, bool)
    keep[5, 5] = True
    fill = np.zeros(frame.shape, bool)
    fill[30, 30] = True
    depth = np.where(fill, np.float32(1.0), np.float32(0))
    out2, repaired2 = repair_frame(frame, pred, mask, 4000.0, SceneRepair(fill, depth, keep))
    assert out2[5, 5] == frame[5, 5] and not repaired2[5, 5]
    assert out2[30, 30] == 4000 and repaired2[30, 30]
    metres = frame.astype(np.float32) / 4000
    same, none = repair_frame(metres, pred, np.zeros(frame.shape, bool), 1.0)
    assert np.array_equal(same, metres) and not none.any()  # metres in, metres out, nothing to repair


def test_a_repair_that_moves_no_return_fills_no_hole():
    """Holes alone are the sensor's own (an L515's flicker): a frame whose repair would only fill them is
    left as it is; once the repair also moves a return, its holes are filled with it."""
    frame = np.full((40, 48), 8000, np.uint16)
    frame[::7, ::5] = 0  # scattered holes, as a sensor's own flicker leaves them
    holes = frame == 0
    pred = np.full(frame.shape, 2.0, np.float32)
    out, repaired = repair_frame(frame, pred, holes, 4000.0)
    assert np.array_equal(out, frame) and not repaired.any()
    for dtype, scale in ((np.uint16, 4000.0), (np.float32, 1.0)):
        bad = frame.astype(np.float32) / 4000 if dtype == np.float32 else frame.copy()
        bad[20:30, 20:30] = 6000 if dtype == np.uint16 else 1.5  # a patch read 50 cm near
        mask = holes.copy()
        mask[20:30, 20:30] = True
        out, repaired = repair_frame(bad, pred, mask, scale)
        assert repaired[20:30, 20:30].all() and repaired[holes].all()
        assert (out[holes] > 0).all()  # filled with the rest of the repair


def test_passes_stop_once_a_pass_finds_nothing_new():
    calls = []

    def raw(metres: np.ndarray, previous: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        calls.append(1)
        logit = np.full(metres.shape, -5.0, np.float32)
        logit[:, 5:10, 5:10] = 5.0
        return logit, np.full(metres.shape, 2.0, np.float32)

    metres = np.full((1, 32, 32), 2.0, np.float32)
    metres[0, 5:10, 5:10] = 1.0  # read a metre near; the model puts it back at the wall
    _, mask = recover_passes(raw, metres, None, 0.0, passes=4)
    assert len(calls) == 2 and mask[0, 5:10, 5:10].all() and mask.sum() == 25  # the second found nothing new


def test_repair_sums_score_rmse_f1_and_clean_pixels_changed():
    clean = np.full((8, 8), 2.0, np.float32)
    hit = np.zeros(clean.shape, bool)
    hit[:2] = True
    x = np.where(hit, np.float32(1.0), clean)  # two rows read a metre near
    perfect, left = RepairSums(), RepairSums()
    perfect.add(clean.copy(), hit.copy(), x, clean, hit)
    left.add(x.copy(), np.zeros_like(hit), x, clean, hit)  # nothing repaired
    good, bad = perfect.result(), left.result()
    assert good["rmse_cm"] == 0 and good["mask_f1"] == 1.0 and good["clean_changed"] == 0
    assert bad["rmse_cm"] == pytest.approx(100 * np.sqrt(16 / 64)) and bad["mask_recall"] == 0
    harm = RepairSums()
    moved = clean.copy()
    moved[7, 7] = 2.5  # a clean pixel moved 50 cm
    harm.add(moved, hit.copy(), x, clean, hit)
    assert harm.result()["clean_changed"] == pytest.approx(1 / 48)


def test_agreement_is_the_share_of_pixels_returning_in_both_that_agree():
    now = np.full((4, 4), 0.5, np.float32)
    before = now.copy()
    now[0, :] = 0  # no return now: not counted, whatever the frame before read
    before[1, :] = 0.9  # 40 cm off: counted, and not agreeing
    assert agreement(now, before) == pytest.approx(8 / 12)
    assert agreement(now, None) == 0.0 and agreement(np.zeros_like(now), before) == 0.0
    with pytest.raises(InputError, match=r"\(2, 2\).*\(4, 4\)"):
        agreement(now, before[:2, :2])


@pytest.mark.parametrize(("read", "predicted"), [(8.0, 9.0), (0.5, 0.2)])
def test_the_guard_s_range_is_the_trusted_returns_never_the_masked_readings(read, predicted):
    """A patch read far (or near) past the wall and predicted farther still: the clamp is the wall's range,
    not one the patch's own wrong readings widen."""
    metres = _wall()
    mask = np.zeros(metres.shape, bool)
    mask[10:20, 10:20] = True
    metres[mask] = read
    p, keep = guard(metres, np.full(metres.shape, predicted, np.float32), mask)
    tol = 0.03 + 0.02 * read
    want = 2.0 + tol if predicted > 2.0 else 2.0 - tol
    assert keep[mask].all() and np.allclose(p[mask], want, atol=1e-5)


@pytest.mark.parametrize("scale", [1000.0, 4000.0, 5000.0])
def test_the_guard_on_the_sensor_s_units_gives_what_it_gives_on_metres(scale):
    """``units`` (the frame as the sensor gave it) finds the trusted neighbours' range on integers, faster:
    the same repair bit for bit, where a masked pixel has trusted neighbours and where a wide masked region
    leaves some with none; the frame's own holes and near and far returns included."""
    from d2sr.frames.base import to_metres

    rng = np.random.default_rng(int(scale))
    units = rng.integers(0, 12 * int(scale), (120, 160)).astype(np.uint16)
    units[rng.random(units.shape) < 0.2] = 0
    metres = to_metres(units, scale)
    mask = rng.random(units.shape) < 0.1
    mask[20:90, 30:120] = True  # wider than the guard's reach: its middle has no trusted neighbour
    pred = (rng.random(units.shape) * 12).astype(np.float32)
    p, keep = guard(metres, pred, mask)
    p2, keep2 = guard(metres, pred, mask, units, scale)
    assert keep.any() and np.array_equal(keep, keep2) and np.array_equal(p, p2)
    assert np.array_equal(
        repair_frame(units, pred, mask, scale)[0],
        repair_frame(units, pred, mask, scale, metres=metres)[0],
    )
