"""The wide interference generator, the sensor kinds and the do-no-harm guard."""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
import pytest

from d2sr.contract.repair import (
    GUARD_PX,
    KEEP_M,
    KEEP_REL,
    LEAVE_REL,
    LONE_MAX,
    LONE_PX,
    guard,
    recover_passes,
    repair_frame,
)
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Intrinsics
from d2sr.sim.families import FAMILIES, WideSettings, shape, wide_interference
from d2sr.sim.rooms import Pose, Renderer, make_room
from d2sr.sim.sensors import SENSOR_KINDS, observe

SMALL = Intrinsics(160, 120, 114.0, 114.0, 80.0, 60.0)


def _clean(scale: float = 1000.0) -> np.ndarray:
    rng = np.random.default_rng(0)
    d = rng.uniform(1.0, 4.0, (120, 160))
    d[rng.random(d.shape) < 0.2] = 0
    return np.rint(d * scale).astype(np.uint16)


@pytest.mark.parametrize("family", FAMILIES)
def test_each_family_marks_exactly_the_changed_pixels(family):
    clean = _clean()
    frame, mask, drawn = wide_interference(clean, 1000.0, 5, WideSettings(families=(family,)))
    assert drawn == [family]
    assert np.array_equal(mask, frame != clean) and mask.any()
    again, _, _ = wide_interference(clean, 1000.0, 5, WideSettings(families=(family,)))
    assert np.array_equal(frame, again)  # a pure function of the seed


def test_coverage_spans_faint_to_heavy():
    clean = _clean()
    shares = [wide_interference(clean, 1000.0, s)[1].mean() for s in range(40)]
    assert min(shares) < 0.01 and max(shares) > 0.15


def test_shapes_aim_at_their_coverage():
    rng = np.random.default_rng(1)
    for family in ("band", "bar", "blob", "region", "grating"):
        got = np.mean([shape(family, (240, 320), 0.2, rng).mean() for _ in range(10)])
        assert 0.05 < got < 0.5, (family, got)


def test_bad_config_and_input_are_refused():
    with pytest.raises(ConfigError, match="families"):  # built directly: d2sr's own error too
        WideSettings(families=("rainbow",))
    with pytest.raises(InputError, match="uint16"):
        wide_interference(np.zeros((8, 8), np.float32), 1000.0, 0)


@pytest.mark.parametrize("kind", SENSOR_KINDS)
def test_sensor_kinds_deliver_uint16_at_their_scale(kind):
    pose = Pose(0.5, 2.0, 1.2, 0.2, -0.1)
    r = Renderer(make_room(3, cameras=[pose], people=0), SMALL, pose).render()
    a, scale = observe(kind, r, np.random.default_rng(7))
    b, _ = observe(kind, r, np.random.default_rng(7))
    assert a.dtype == np.uint16 and a.shape == (120, 160) and np.array_equal(a, b)
    assert scale in (1000.0, 4000.0, 5000.0)
    ok = (a > 0) & (a < 65535) & (r.depth > 0)
    err = np.abs(a[ok] / scale - r.depth[ok]) / r.depth[ok]
    assert ok.mean() > 0.1 and np.median(err) < 0.03  # mostly the scene, with this sensor's artefacts


def test_guard_leaves_noise_alone_and_clamps_to_the_neighbours():
    x = np.full((64, 64), 2.0, np.float32)
    mask = np.zeros(x.shape, bool)
    mask[20:24, 20:24] = True
    # within the sensor's noise: nothing moves
    p, m = guard(x, x + 0.01, mask)
    assert not m.any()
    # an invented near surface is pulled back to the neighbours' range (2 m +- tolerance)
    p, m = guard(x, np.full_like(x, 0.5), mask)
    assert (p[20:24, 20:24] >= 1.929).all() and (np.abs(p - x)[m] <= 0.0701).all()
    x[20:24, 20:24] = 0.7  # a too-short patch; neighbours at 2 m
    p, m = guard(x, np.full_like(x, 2.0), mask)
    assert m[20:24, 20:24].all() and np.allclose(p[20:24, 20:24], 2.0)


def test_guard_leaves_a_return_within_the_models_own_error():
    x = np.full((64, 64), 2.0, np.float32)
    mask = np.zeros(x.shape, bool)
    mask[20:24, 20:24] = True
    x[20:22, 20:24] = 1.4  # 30% short: repaired
    x[22:24, 20:24] = 1.85  # 7.5% short: as likely the model's error as the pixel's, left alone
    _, m = guard(x, np.full_like(x, 2.0), mask)
    assert m[20:22, 20:24].all() and not m[22:24].any()
    out, kept = repair_frame(np.rint(x * 1000).astype(np.uint16), np.full_like(x, 2.0), mask, 1000.0)
    assert (kept == m).all() and (out[22:24, 20:24] == 1850).all() and (out[20:22, 20:24] == 2000).all()


def test_guard_keeps_predictions_where_no_trusted_pixel_is_near():
    x = np.full((64, 64), 2.0, np.float32)
    mask = np.ones(x.shape, bool)
    x[:, :32] = 0.5
    p, m = guard(x, np.full_like(x, 2.0), mask)
    assert m[:, :32].all() and np.allclose(p[:, :32], 2.0)


def test_guard_leaves_lone_returns_and_repairs_a_wrong_surface():
    # Mostly no return, a far wall on the right, and scattered lone returns at 1.2 m (a sensor's own, or
    # wrong: nothing around them says which). A model that moves them to the wall is not followed.
    x = np.zeros((64, 64), np.float32)
    x[:, 40:] = 3.8
    lone = np.zeros(x.shape, bool)
    lone[4:36:7, 3:36:6] = True
    x[lone] = 1.2
    x[50:60, 10:20] = 1.2  # a small surface of its own: its returns are not lone
    mask = np.zeros(x.shape, bool)
    mask[:, :40] = True
    p, m = guard(x, np.full_like(x, 3.8), mask)
    assert not m[lone].any() and (x[lone] == np.float32(1.2)).all()
    assert m[50:60, 10:20].all() and np.allclose(p[50:60, 10:20], 3.8)
    assert m[(x == 0) & mask].all()  # the dropouts are still filled
    # the centre of a 9x9 frame with LONE_MAX + 1 other returns is on a surface; with LONE_MAX, lone
    y = np.zeros((9, 9), np.float32)
    y[4, 4] = 1.0
    y.ravel()[: LONE_MAX + 1] = 1.0
    _, m = guard(y, np.full_like(y, 3.0), np.ones(y.shape, bool))
    assert m[4, 4]
    y.ravel()[LONE_MAX] = 0.0
    _, m = guard(y, np.full_like(y, 3.0), np.ones(y.shape, bool))
    assert not m[4, 4]


def _guard_rule(x: np.ndarray, pred: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """guard's rule written out over the whole frame: no crop to the mask, no gathers."""
    trusted = (x > 0) & ~mask
    k = np.ones((2 * GUARD_PX + 1, 2 * GUARD_PX + 1), np.uint8)
    lo = cv2.erode(np.where(trusted, x, np.float32(np.inf)), k)
    hi = cv2.dilate(np.where(trusted, x, np.float32(0)), k)
    tol = np.float32(KEEP_M) + np.float32(KEEP_REL) * x
    p = np.where(hi > 0, np.clip(pred, lo - tol, hi + tol), pred)
    side = 2 * LONE_PX + 1
    around = cv2.boxFilter(
        (x > 0).astype(np.float32), -1, (side, side), normalize=False, borderType=cv2.BORDER_CONSTANT
    )
    lone = around <= LONE_MAX + 1
    keep = mask & ~((x > 0) & ((np.abs(p - x) <= np.float32(KEEP_M) + np.float32(LEAVE_REL) * x) | lone))
    return p, keep


def test_guard_is_its_rule_over_the_whole_frame():
    # guard only works near the mask (a crop, then the masked pixels): that must change nothing.
    rng = np.random.default_rng(4)
    for share in (0.0, 0.001, 0.02, 0.3, 1.0):
        for _ in range(4):
            h, w = (int(v) for v in rng.integers(3, 80, 2))
            x = (rng.uniform(0.3, 5, (h, w)) * (rng.random((h, w)) > 0.2)).astype(np.float32)
            pred = rng.uniform(0, 6, (h, w)).astype(np.float32)
            mask = rng.random((h, w)) < share
            mask[: int(rng.integers(0, 3)), :] |= share > 0  # masked rows along an edge
            p, keep = guard(x, pred, mask)
            rp, rk = _guard_rule(x, pred, mask)
            assert np.array_equal(keep, rk) and np.array_equal(p[mask], rp[mask])
            assert np.array_equal(p[~mask], pred[~mask])  # nothing outside the mask is repaired


def _wide_wrong_surface() -> tuple[np.ndarray, list[np.ndarray], Callable]:
    """A wall at 2 m with a band at 0.8 m over columns 20-44; a stand-in model that flags only the band's
    pixels next to a correct one (a wrong surface shows only at its edges) and predicts 2 m there."""
    x = np.full((1, 64, 64), 2.0, np.float32)
    x[:, :, 20:44] = 0.8
    seen: list[np.ndarray] = []

    def raw(m: np.ndarray, _prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        seen.append(m.copy())
        wrong = m < 1.5
        edge = wrong & ~(np.roll(wrong, 3, axis=2) & np.roll(wrong, -3, axis=2))
        return np.where(edge, 5.0, -5.0).astype(np.float32), np.full_like(m, 2.0)

    return x, seen, raw


def test_each_pass_sees_the_last_repair_and_keeps_what_it_found():
    x, seen, raw = _wide_wrong_surface()
    _, one = recover_passes(raw, x, None, 0.0, 1)
    assert one[0, :, 20:23].all() and not one[0, :, 26:38].any()
    seen.clear()
    pred, many = recover_passes(raw, x, None, 0.0, 8)
    assert many[0, :, 20:44].all() and not many[0, :, :20].any() and not many[0, :, 44:].any()
    assert np.array_equal(seen[0], x) and len(seen) < 8  # stopped once the band was filled in
    assert (seen[1][0, :, 20:23] == 2.0).all() and (seen[1][0, :, 26:38] == np.float32(0.8)).all()
    assert np.allclose(pred[many], 2.0)


def test_a_pass_that_repairs_nothing_ends_it():
    x, seen, raw = _wide_wrong_surface()
    x[:] = 2.0  # clean: nothing flagged, the model runs once
    _, mask = recover_passes(raw, x, None, 0.0, 4)
    assert not mask.any() and len(seen) == 1


def test_repair_frame_is_bit_identical_outside_what_it_repaired():
    f = _clean()
    pred = np.full(f.shape, 3.0, np.float32)
    mask = np.zeros(f.shape, bool)
    mask[10:40, 10:40] = True
    out, kept = repair_frame(f, pred, mask, 1000.0)
    assert not (kept & ~mask).any()
    assert np.array_equal(out[~kept], f[~kept])
    assert (out[kept] != f[kept]).all()


def test_generalization_reads_each_shared_set_at_its_true_scale(tmp_path):
    import cv2

    from d2sr.eval.generalization import _nyu, _sun, real_clean_sets

    v = np.array([[0, 1000, 2500, 8000]], np.uint16)
    raw = ((v.astype(np.uint32) << 3) | (v.astype(np.uint32) >> 13)) & 0xFFFF
    assert np.array_equal(_sun(raw.astype(np.uint16)), v)  # SUN stores its millimetres bit-rotated
    disp = np.array([[2047, 500]], np.uint16).byteswap()  # NYU: raw disparity, byte-swapped
    assert _nyu(disp)[0, 0] == 0 and abs(int(_nyu(disp)[0, 1]) - 593) <= 1  # 351.3 / (1092.5 - 500) m
    (tmp_path / "d435").mkdir()
    (tmp_path / "open3d_rgbd").mkdir()
    for i in range(3):
        cv2.imwrite(str(tmp_path / "d435" / f"depth{i:05d}.png"), np.full((48, 64), 800, np.uint16))
    cv2.imwrite(str(tmp_path / "open3d_rgbd" / "TUM_depth.png"), np.full((48, 64), 12000, np.uint16))
    sets = {s.name: s for s in real_clean_sets(tmp_path)}
    assert set(sets) == {"D435", "TUM"}
    assert sets["D435"].scale == 1000 and len(sets["D435"].frames) == 3 and sets["TUM"].scale == 5000
    with pytest.raises(InputError, match="none of the shared"):
        real_clean_sets(tmp_path / "nothing")


def test_gratings_repeat_across_the_view():
    import cv2

    rng = np.random.default_rng(2)
    counts = []
    for _ in range(12):
        g = shape("grating", (240, 320), 0.3, rng)
        counts.append(cv2.connectedComponents(g.astype(np.uint8))[0] - 1)
        assert 0.1 < g.mean() < 0.5
    assert max(counts) >= 8  # dense: many stripes or rings, not a few bands


class _Stub:
    """A backend that scores every frame 0.9 and repairs the pixels nearer than 1.5 m to 3 m (or none)."""

    threshold = 0.5
    frames = 1

    def __init__(self, repairs: bool, detector: bool = True) -> None:
        self.repairs, self.detector = repairs, detector

    def scores(self, metres, previous=None, cut=None):
        assert self.detector, "a recovery-only model was asked for a score"
        return np.full(len(metres), 0.9, np.float32)

    def recover(self, metres, previous=None):
        mask = (metres > 0) & (metres < 1.5) if self.repairs else np.zeros(metres.shape, bool)
        return np.full(metres.shape, 3.0, np.float32), mask


def test_family_rows_report_recovery_trained_without_the_family():
    from d2sr.eval.generalization import RealSet, family_rows

    frames = [_clean(4000.0) for _ in range(4)]
    sets = [RealSet("L515 dev0", "L515", frames, 4000.0)]
    lofo = {"band": _Stub(False, detector=False), "all": _Stub(True, detector=False)}
    rows = family_rows(_Stub(True), sets, families=("band", "blob"), lofo_recovery=lofo)
    band, blob = rows
    assert band["mask_f1_left_out"] == 0.0  # the left-out model repaired nothing
    assert band["mask_f1_same_recipe"] == band["mask_f1"] and band["mask_f1"] >= 0  # same stub as the net
    assert "mask_f1_left_out" not in blob and "mask_f1_same_recipe" not in blob  # none trained without blob
