"""Frame synthesis (d2sr.synth, d2sr fill): the warp against rendered ground truth, the colour path on a
textured wall seen from two poses, the recording job's outputs and refusals."""

from __future__ import annotations

import csv

import cv2
import numpy as np
import pytest

from d2sr.errors import ConfigError, InputError
from d2sr.synth import Filler, FillSettings, Pose, fill_recording, warp_depth
from d2sr.synth.recording import kept
from d2sr.synth.warp import fill_from_background
from helpers import K, colour_of_wall, d2sr_inprocess, texture


def _render(t: np.ndarray) -> np.ndarray:
    """Depth (m) of a wall at z = 3 with a box (z = 2, a square in the middle) for a camera translated by
    ``t`` (no rotation): each pixel's ray meets the nearest surface."""
    v, u = np.mgrid[0 : K.height, 0 : K.width].astype(np.float64)
    dx, dy = (u - K.px) / K.fx, (v - K.py) / K.fy
    depth = np.full(u.shape, 3.0 - t[2])
    zb = 2.0 - t[2]
    x, y = dx * zb + t[0], dy * zb + t[1]
    box = (np.abs(x) < 0.4) & (np.abs(y) < 0.4)
    depth[box] = zb
    return depth.astype(np.float32)


def test_identity_warp_gives_the_frame_back():
    d = _render(np.zeros(3))
    assert np.allclose(warp_depth(d, Pose.identity(), K), d, atol=1e-5)


def test_warp_matches_what_the_moved_camera_sees():
    t = np.array([0.06, -0.02, 0.05])
    before, after = _render(np.zeros(3)), _render(t)
    warped = warp_depth(before, Pose(np.eye(3), -t), K)  # points move opposite to the camera
    has = warped > 0
    assert has.mean() > 0.9  # the move uncovers a sliver beside the box and an edge strip
    err = np.abs(warped[has] - after[has])
    assert np.mean(err < 0.02) > 0.99  # all but the box's edge pixels, which rounding puts on either side
    filled, conf = fill_from_background(warped, 16)
    assert (filled > 0).mean() > has.mean() and np.all(conf[has] == 1) and np.all(conf[~has] < 1)
    new = (filled > 0) & ~has
    assert np.median(np.abs(filled[new] - after[new])) < 0.05  # uncovered wall filled as wall


def test_filler_follows_odometry_and_holds_without_it():
    f = Filler(K)
    before, after = _render(np.zeros(3)), _render(np.array([0.08, 0.0, 0.0]))
    assert f.real(before, pose=Pose.identity()).method == "real"
    s = f.synthesize(pose=Pose(np.eye(3), np.array([0.08, 0.0, 0.0])))  # camera to world
    has = s.confidence == 1
    assert s.method == "warp-pose" and s.since_real == 1 and has.mean() > 0.9
    assert np.mean(np.abs(s.depth[has] - after[has]) < 0.02) > 0.99
    held = f.synthesize()
    assert held.method == "hold" and np.array_equal(held.depth, before) and held.confidence.max() == 0.5


def test_colour_path_finds_the_motion_of_a_textured_wall():
    tex = texture()
    wall = np.full((K.height, K.width), 3.0, np.float32)
    f = Filler(K)
    f.real(wall, colour_of_wall(np.zeros(3), tex))
    t = np.array([0.0, 0.0, 0.0])
    for step in range(1, 6):  # the camera walks 4 cm a frame towards the wall
        t = np.array([0.0, 0.0, 0.04 * step])
        s = f.synthesize(colour_of_wall(t, tex))
        assert s.method == "warp-colour"
    has = s.confidence == 1
    assert has.mean() > 0.8
    assert np.abs(np.median(s.depth[has]) - (3.0 - t[2])) < 0.03  # 20 cm closer, seen from colour alone


def test_window_slots():
    assert [kept(i, 6, 0) for i in (0, 5, 6, 29, 30, 35, 36)] == [True, True, False, False, True, True, False]
    assert [kept(i, 6, 27) for i in (26, 27, 29, 30, 32, 33)] == [False, True, True, True, True, False]


def _sequence(tmp_path, n: int = 40, colour: bool = True):
    depth_dir, rgb_dir = tmp_path / "depth", tmp_path / "rgb"
    depth_dir.mkdir()
    rgb_dir.mkdir()
    tex = texture(1)
    for i in range(n):
        t = np.array([0.004 * i, 0.0, 0.0])
        d = np.rint(np.full((K.height, K.width), 3.0 - t[2]) * 1000).astype(np.uint16)
        d[::37, ::41] = 0  # missing returns
        cv2.imwrite(str(depth_dir / f"depth{i:05d}.png"), d)
        if colour:
            cv2.imwrite(str(rgb_dir / f"rgb{i:05d}.jpg"), colour_of_wall(t, tex))
    return depth_dir, rgb_dir


def test_fill_keeps_the_window_and_synthesizes_the_rest(tmp_path):
    depth_dir, rgb_dir = _sequence(tmp_path)
    summary = fill_recording(
        depth_dir, tmp_path / "out", FillSettings(active_frames=6, offset=2, colour=rgb_dir)
    )
    out = tmp_path / "out"
    assert (summary.frames, summary.kept, summary.synthesized) == (40, 6 + 6, 28)
    rows = list(csv.DictReader((out / "fill.csv").open()))
    assert [r["synthesized"] for r in rows[:9]] == ["1", "1", "0", "0", "0", "0", "0", "0", "1"]
    assert (
        rows[0]["method"] == "none"
        and rows[8]["method"] == "warp-colour"
        and rows[8]["frames_since_real"] == "1"
    )
    for r in rows:
        src = cv2.imread(str(depth_dir / f"{r['frame']}.png"), cv2.IMREAD_UNCHANGED)
        got = cv2.imread(str(out / f"{r['frame']}.png"), cv2.IMREAD_UNCHANGED)
        conf = cv2.imread(str(out / "confidence" / f"{r['frame']}.png"), cv2.IMREAD_UNCHANGED)
        assert got.dtype == np.uint16 and conf.dtype == np.uint8 and got.shape == src.shape
        if r["synthesized"] == "0":
            assert np.array_equal(got, src)  # kept frames exactly as they were
        elif r["method"] == "warp-colour":
            near = conf == 255
            assert np.abs(got[near].astype(int) - 3000).max() <= 45  # 1.5%: the motion is estimated


def test_fill_without_colour_holds_the_last_kept_frame(tmp_path):
    depth_dir, _ = _sequence(tmp_path, n=12, colour=False)
    code, out, err = d2sr_inprocess(
        "fill", str(depth_dir), "--active-frames", "6", "--out", str(tmp_path / "o")
    )
    assert code == 0, err
    assert "12 frames: 6 kept, 6 synthesized (hold;" in out
    last = cv2.imread(str(depth_dir / "depth00005.png"), cv2.IMREAD_UNCHANGED)
    assert np.array_equal(cv2.imread(str(tmp_path / "o" / "depth00009.png"), cv2.IMREAD_UNCHANGED), last)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--active-frames", "0"], "--active-frames: Input should be greater than or equal to 1"),
        (["--active-frames", "6", "--offset", "30"], "--offset: "),
        (["--active-frames", "6", "--colour", "NOPE"], "no such folder"),
    ],
)
def test_fill_refuses_bad_settings(tmp_path, args, message):
    depth_dir, _ = _sequence(tmp_path, n=3, colour=False)
    args = [str(tmp_path / "nope") if a == "NOPE" else a for a in args]
    code, _, err = d2sr_inprocess("fill", str(depth_dir), *args, "--out", str(tmp_path / "o"))
    assert code == 2 and message in err and err.count("\n") == 1 and not (tmp_path / "o").exists()


def test_fill_refuses_too_few_colour_frames(tmp_path):
    depth_dir, rgb_dir = _sequence(tmp_path, n=5)
    (rgb_dir / "rgb00004.jpg").unlink()
    with pytest.raises(InputError, match="4 colour frames for 5 depth frames"):
        fill_recording(depth_dir, tmp_path / "o", FillSettings(active_frames=2, colour=rgb_dir))
    with pytest.raises(ConfigError):
        fill_recording(depth_dir, tmp_path / "o", FillSettings(active_frames=31))


def test_pipeline_synthesizes_skipped_slots_in_the_callers_units():
    import d2sr

    tex = texture(2)
    p = d2sr.Pipeline(depth_scale=1000, intrinsics=K, repair="none")
    with pytest.raises(InputError, match="no frame processed yet"):
        p.synthesize()
    wall = np.full((K.height, K.width), 3000, np.uint16)
    r = p.process(wall, colour=colour_of_wall(np.zeros(3), tex))
    assert np.array_equal(r.depth, wall)
    t = np.array([0.0, 0.0, 0.1])
    s = p.synthesize(colour_of_wall(t, tex))
    assert s.method == "warp-colour" and s.depth.dtype == np.uint16 and s.since_real == 1
    near = s.confidence == 1
    assert abs(int(np.median(s.depth[near])) - 2900) <= 30
    f = d2sr.Pipeline(intrinsics=K, repair="none")
    f.process(wall.astype(np.float32) / 1000)
    held = f.synthesize()
    assert held.method == "hold" and held.depth.dtype == np.float32 and np.allclose(held.depth, 3.0)


def test_a_colour_step_that_cannot_be_measured_is_said_as_a_guess():
    """A real frame that came without colour gives the first frame synthesized from colour no step to
    measure: it is the real one where it was, at a held frame's confidence, not 1; the next is measured."""
    tex = texture()
    wall = np.full((K.height, K.width), 3.0, np.float32)
    f = Filler(K)
    f.real(wall)  # no colour with it
    first = f.synthesize(colour_of_wall(np.array([0.0, 0.0, 0.04]), tex))
    assert first.method == "warp-colour" and first.confidence.max() <= 0.5
    second = f.synthesize(colour_of_wall(np.array([0.0, 0.0, 0.08]), tex))
    assert (second.confidence == 1).mean() > 0.8


def test_a_still_camera_with_noisy_colour_gives_the_real_frame_back():
    """Fresh sensor noise on every colour frame of a camera that does not move: PnP reads small steps into
    it, and chained they drift. The matches to the real frame do not show motion, so each synthesized frame
    is the real one, as holding it would be (a still sensor's frames are no worse than hold-last)."""
    tex = texture(5)
    v, u = np.mgrid[0 : K.height, 0 : K.width]
    depth = (2.0 + 0.8 * (u > K.width // 2) + 0.001 * v).astype(np.float32)  # two planes, one tilted
    still = colour_of_wall(np.zeros(3), tex)
    rng = np.random.default_rng(0)

    def noisy() -> np.ndarray:
        return np.clip(still + rng.normal(0, 2.0, still.shape), 0, 255).astype(np.uint8)

    f = Filler(K)
    f.real(depth, noisy())
    for _ in range(24):
        s = f.synthesize(noisy())
        assert s.method == "warp-colour" and np.array_equal(s.depth, depth)


def test_colour_alone_follows_the_simulated_robot():
    """The simulator's colour camera (``d2sr.sim.colour``) on the moving robot: the motion read from colour
    alone agrees with the trajectory's to a few millimetres over three frames."""
    from d2sr.jobs.session import odometry, rig_intrinsics
    from d2sr.sim.colour import grey
    from d2sr.sim.rooms import Renderer
    from d2sr.sim.world import make_rig

    rig = make_rig(0, sensors=2, moving_robot=True)
    cam = Renderer(rig.room, rig.intr)
    f = Filler(rig_intrinsics(rig))
    rng = np.random.default_rng(0)

    def at(i: int) -> tuple[np.ndarray, np.ndarray, Pose]:
        cam.move(rig.pose(1, i / 30))
        r = cam.render(i / 30)
        return r.depth.astype(np.float32), grey(cam, r, 2.0, rng), odometry(rig, 1, i / 30)

    depth, image, start = at(10)
    f.real(depth, image)
    for i in (11, 12, 13):
        depth, image, pose = at(i)
        s = f.synthesize(image)
    truth = start.then(pose.inverse())
    assert s.method == "warp-colour" and np.linalg.norm(truth.t) > 0.03
    assert np.linalg.norm(f._moved.t - truth.t) < 0.2 * np.linalg.norm(truth.t)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"radius": -1}, "radius"),  # a ValueError from numpy on the first warp before
        ({"radius": 10**9}, "radius"),  # a kernel of 10^18 bytes
        ({"radius": 2.5}, "radius"),
        ({"radius": True}, "radius"),
        ({"intrinsics": "fx=500"}, "intrinsics must be"),  # an AttributeError on the first warp before
    ],
)
def test_a_filler_refuses_settings_no_fill_could_use(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        Filler(**kwargs)


def test_a_real_frame_reads_what_is_not_a_positive_finite_depth_as_no_return():
    """Float depth marks no return as 0, NaN or a negative value, by driver: none of them comes back as a
    depth, and a held frame holds none of them."""
    metres = np.full((30, 40), 2.0, np.float32)
    metres[0, :3] = [np.nan, -1.0, np.inf]
    f = Filler(K.scaled(40, 30), radius=0)
    real = f.real(metres)
    held = f.synthesize()
    for s in (real, held):
        assert (s.depth[0, :3] == 0).all() and (s.confidence[0, :3] == 0).all()
        assert np.isfinite(s.depth).all() and (s.depth >= 0).all()
    assert (held.depth[1:] == 2.0).all()
