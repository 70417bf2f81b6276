"""Scenes (the simulator's rooms), renderer, sensor model, interference and multi-sensor geometry."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from d2sr.errors import InputError
from d2sr.frames import Intrinsics
from d2sr.sim.interference import InterferenceSettings, Interferer, corrupt, interfere
from d2sr.sim.rooms import L515, Box, Person, Pose, Renderer, Room, SensorNoise, make_room
from d2sr.sim.world import lit_region, make_rig, overlap_graph

SMALL = Intrinsics(160, 120, 114.0, 114.0, 80.0, 60.0)
EMPTY = Room((6.0, 4.0, 3.0), (0.5,) * 6)


def test_wall_depth_is_z_depth():
    cam = Renderer(EMPTY, SMALL, Pose(1.0, 2.0, 1.5, 0.0))
    r = cam.render()
    # facing +x: the far wall is 5 m ahead; z-depth is the same on the whole wall
    assert r.depth[60, 80] == pytest.approx(5.0, abs=1e-4)
    assert r.depth[60, 40] == pytest.approx(5.0, abs=1e-4)
    assert r.cos[60, 80] == pytest.approx(1.0, abs=0.01)
    assert r.cos[60, 0] < r.cos[60, 80]


def test_box_occludes_and_turned_box_renders():
    box = Box((2.5, 1.5, 0.0), (3.0, 2.5, 3.0), refl=0.9)
    room = Room(EMPTY.size, EMPTY.face_refl, (box,))
    r = Renderer(room, SMALL, Pose(1.0, 2.0, 1.5, 0.0)).render()
    assert r.depth[60, 80] == pytest.approx(1.5, abs=1e-4)
    assert r.refl[60, 80] == pytest.approx(0.9)
    turned = Box(box.lo, box.hi, 0.9, yaw=np.pi / 4)
    r2 = Renderer(Room(EMPTY.size, EMPTY.face_refl, (turned,)), SMALL, Pose(1.0, 2.0, 1.5, 0.0)).render()
    assert 1.0 < r2.depth[60, 80] < 1.75  # the corner of the turned box comes closer than its face


def test_people_move_and_cache_is_not_changed():
    walker = Person(((3.0, 2.0), (3.0, 2.0001)), speed=0.0)
    room = Room(EMPTY.size, EMPTY.face_refl, (), (walker,))
    cam = Renderer(room, SMALL, Pose(1.0, 2.0, 1.0, 0.0))
    r = cam.render(0.0)
    assert r.depth[60, 80] == pytest.approx(2.0 - walker.radius, abs=0.01)
    assert cam.static().depth[60, 80] == pytest.approx(5.0, abs=1e-4)
    moving = Person(((3.0, 0.5), (3.0, 3.5)), speed=1.0)
    cam2 = Renderer(Room(EMPTY.size, EMPTY.face_refl, (), (moving,)), SMALL, Pose(1.0, 2.0, 1.0, 0.0))
    assert not np.array_equal(cam2.render(0.0).depth, cam2.render(1.0).depth)


def test_sensor_model_drops_more_far_and_dark():
    near = Renderer(Room((3.0, 4.0, 3.0), (0.6,) * 6), SMALL, Pose(0.5, 2.0, 1.5, 0.0)).render()
    far = Renderer(Room((8.5, 4.0, 3.0), (0.6,) * 6), SMALL, Pose(0.5, 2.0, 1.5, 0.0)).render()
    dark = Renderer(Room((3.0, 4.0, 3.0), (0.01,) * 6), SMALL, Pose(0.5, 2.0, 1.5, 0.0)).render()
    noise = SensorNoise(L515, near.depth.shape, 0)
    zeros = {
        k: np.mean([noise.observe(r) == 0 for _ in range(5)])
        for k, r in (("near", near), ("far", far), ("dark", dark))
    }
    assert zeros["near"] < zeros["far"] and zeros["near"] < zeros["dark"]
    f = noise.observe(near)
    assert f.dtype == np.uint16
    ok = f[60, 60:100] > 0
    assert np.allclose(f[60, 60:100][ok] / L515.depth_scale, 2.5, atol=0.05)


def test_sensor_noise_is_reproducible():
    r = Renderer(make_room(1), SMALL, Pose(0.5, 2.0, 1.5, 0.3)).render()
    a = [SensorNoise(L515, r.depth.shape, 3).observe(r) for _ in range(2)]
    assert np.array_equal(a[0], a[1])


def test_lone_dropouts_follow_the_fitted_rate_and_come_back_on_weak_pixels():
    from d2sr.sim.calibrate import pinholes
    from d2sr.sim.rooms import PINHOLE_REPEAT

    # A near bright wall: the return law keeps almost every pixel, so lone holes are the pinhole ones.
    r = Renderer(Room((3.0, 4.0, 3.0), (0.9,) * 6), SMALL, Pose(0.5, 2.0, 1.5, 0.0)).render()
    none = SensorNoise(L515.model_copy(update={"pinhole": 0.0}), r.depth.shape, 0)
    some = SensorNoise(L515.model_copy(update={"pinhole": 0.05}), r.depth.shape, 0)
    frames = [some.observe(r) for _ in range(40)]
    assert pinholes(none.observe(r) > 0) < 0.01
    assert np.median([pinholes(f > 0) for f in frames]) == pytest.approx(0.05, abs=0.015)
    # A pixel that dropped out alone drops out again at about the repeat rate, not the overall one.
    lone = [(f == 0) & some.weak for f in frames]
    again = np.mean([(a & b).sum() / max(a.sum(), 1) for a, b in itertools.pairwise(lone)])
    assert again == pytest.approx(PINHOLE_REPEAT, abs=0.1)


def test_fine_speckle_makes_small_holes_and_zero_leaves_the_field_as_it_was():
    from d2sr.sim.calibrate import small_holes

    r = Renderer(Room((7.5, 4.0, 3.0), (0.3,) * 6), SMALL, Pose(0.5, 2.0, 1.5, 0.0)).render()  # weak, far
    plain = L515.model_copy(update={"speckle_fine": 0.0, "pinhole": 0.0})
    fine = plain.model_copy(update={"speckle_fine": 0.6})
    a, b = SensorNoise(plain, r.depth.shape, 4), SensorNoise(fine, r.depth.shape, 4)
    fa, fb = [a.observe(r) for _ in range(8)], [b.observe(r) for _ in range(8)]
    assert np.mean([small_holes(f > 0) for f in fb]) > 2 * np.mean([small_holes(f > 0) for f in fa])
    # The same zero share: the fine part changes the shape of the dropouts, not their number.
    assert np.mean([(f == 0).mean() for f in fb]) == pytest.approx(
        np.mean([(f == 0).mean() for f in fa]), abs=0.05
    )


def test_small_holes_counts_holes_of_2_to_10_pixels():
    from d2sr.sim.calibrate import small_holes

    ok = np.ones((20, 20), bool)
    ok[2, 2] = False  # 1 pixel: not counted
    ok[5, 5:8] = False  # 3 pixels
    ok[10:14, 10:14] = False  # 16 pixels: not counted
    ok[17, 0:2] = False  # 2 pixels
    assert small_holes(ok) == pytest.approx(5 / ok.sum())


def test_pinholes_counts_holes_with_returning_neighbours_only():
    from d2sr.sim.calibrate import pinholes

    ok = np.ones((10, 10), bool)
    ok[5, 5] = False  # a lone hole
    ok[0, 0] = False  # a corner has 3 neighbours: not lone
    ok[2:4, 7:9] = False  # a 2x2 hole: each has 5 returning neighbours (counts), as the real captures' do
    assert pinholes(ok) == pytest.approx(5 / ok.sum())
    assert pinholes(np.zeros((4, 4), bool)) == 0.0


def _frame(shape=(120, 160)) -> np.ndarray:
    rng = np.random.default_rng(0)
    f = rng.integers(8000, 20000, shape).astype(np.uint16)
    f[rng.random(shape) < 0.5] = 0
    return f


def test_mask_marks_exactly_the_changed_pixels_and_respects_region():
    f = _frame()
    region = np.zeros(f.shape, bool)
    region[:, :80] = True
    its = [Interferer.draw(f.shape, s) for s in range(3)]
    g, m = interfere(f, 4000.0, its, 5, seed=1, region=region)
    assert np.array_equal(m, g != f)
    assert m.any() and not m[:, 80:].any()
    changed = g[m].astype(float) / 4000
    before = f[m].astype(float) / 4000
    short = (changed > 0) & (before > 0) & (changed < before)
    assert short.sum() > ((changed > before) & (before > 0)).sum()  # mostly too short, some far


def test_more_interferers_corrupt_more():
    f = _frame()
    shares = []
    for k in (1, 2, 4):
        its = [Interferer.draw(f.shape, 10 + s) for s in range(k)]
        shares.append(np.mean([interfere(f, 4000.0, its, t, seed=2)[1].mean() for t in range(6)]))
    assert shares[0] < shares[1] < shares[2]


@pytest.mark.parametrize("kind", ["band", "wave", "bar", "cluster"])
def test_patterns_drift_between_frames(kind):
    it = Interferer((120, 160), kind, 3, 0.15, 12.0)
    a, b = it.pattern(0), it.pattern(1)
    assert a.any() and b.any() and not np.array_equal(a, b)


def test_interference_rejects_bad_frames_and_config():
    with pytest.raises(InputError, match="uint16"):
        interfere(np.zeros((4, 4), np.float32), 4000.0, [], 0, 0)
    with pytest.raises(Exception, match="dropout"):
        InterferenceSettings.make(dropout=0.8, short=0.5)
    _, m = corrupt(_frame(), 4000.0, np.zeros((120, 160), bool), np.random.default_rng(0))
    assert not m.any()


def test_views_that_face_each_other_overlap():
    rig = make_rig(2, 3, intr=SMALL)
    g = overlap_graph(rig, 5.0)
    assert g.live is None and g.src.size >= 4  # sensors around one room, all looking into the middle
    cams = [Renderer(rig.room, SMALL, p) for p in rig.poses]
    lit = lit_region(cams[0], cams[0].static().depth, cams[1], cams[1].static().depth)
    assert 0.02 < lit.mean() < 1.0
    away = Renderer(
        rig.room, SMALL, Pose(rig.poses[1].x, rig.poses[1].y, rig.poses[1].z, rig.poses[1].yaw + np.pi)
    )
    assert lit_region(cams[0], cams[0].static().depth, away, away.static().depth).mean() < lit.mean()


def test_moving_robot_schedules_the_overlap():
    rig = make_rig(1, 3, moving_robot=True, intr=SMALL)
    assert rig.moving() and rig.pose(2, 0.0) != rig.pose(2, 3.0)
    g = overlap_graph(rig, 20.0)
    assert g.live is not None and g.live.shape[1] == 20


def test_sensor_defaults_are_the_committed_calibration():
    import json
    from pathlib import Path

    fitted = json.loads((Path(__file__).parents[2] / "docs/results/sim/calibration.json").read_text())[
        "model"
    ]
    for key, value in L515.model_dump().items():
        assert fitted[key] == pytest.approx(value, rel=1e-3), key  # defaults keep 4 digits


def test_bisect_finds_the_target_and_stops_at_the_nearer_end_outside_the_range():
    from d2sr.sim.calibrate import _bisect

    assert _bisect(lambda x: 2 * x, 0.0, 1.0, 1.0, 12, log=False) == pytest.approx(0.5, abs=1e-3)
    assert _bisect(lambda x: 2 * x, 0.0, 1.0, 5.0, 12, log=False) == 1.0
    assert _bisect(lambda x: -x, 0.0, 1.0, 0.5, 12, log=False) == 0.0  # decreasing, target above f(lo)


def test_colour_is_fixed_to_the_world():
    """The colour camera's texture stays on the surface as the camera moves, so motion can be read from it."""
    from d2sr.sim.colour import grey

    room = Room((6.0, 4.0, 3.0), (0.5, 0.6, 0.7, 0.8, 0.3, 0.7))
    a = Renderer(room, SMALL, Pose(1.0, 2.0, 1.5, 0.0))
    b = Renderer(room, SMALL, Pose(1.0, 2.1, 1.5, 0.0))  # 10 cm to the left (+y): the wall moves right
    ga, gb = grey(a, a.render()), grey(b, b.render())
    assert ga.std() > 10 and np.array_equal(ga, grey(a, a.render()))  # textured, and deterministic
    # the far wall (5 m) shifts by fx * 0.1 / 5 = 2.3 px: matching the shifted image, not the same pixels
    wall = (slice(40, 80), slice(40, 120))
    shifted = np.abs(gb[wall].astype(int) - np.roll(ga, 2, axis=1)[wall]).mean()
    unshifted = np.abs(gb[wall].astype(int) - ga[wall]).mean()
    assert shifted < 0.5 * unshifted
    noisy = grey(a, a.render(), 2.0, np.random.default_rng(0))
    assert 0 < np.abs(noisy.astype(int) - ga).mean() < 3
