"""The still sensor's scene reference (d2sr.scene) and the loop that weighs the detector against it."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pytest

from d2sr.desync import make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.scene import SceneReference, SceneSettings
from helpers import FakeNet

SCALE = 4000.0
SHIPPED = SceneSettings()
EVIDENT, OFF_AREA, QUIET, SHIFT_PX = SHIPPED.evident, SHIPPED.off_area, SHIPPED.quiet, SHIPPED.shift_px
SHIFT_RATE, STILL_SHARE, TRUST_RATE = SHIPPED.shift_rate, SHIPPED.still_share, SHIPPED.trust_rate
NEVER = 1.0  # an area no frame's evidence exceeds: that kind of evidence never flags


def _ref(**settings: object) -> SceneReference:
    return SceneReference(SCALE, SceneSettings(**settings))


def _scene(rng: np.random.Generator, shape: tuple[int, int] = (96, 128)) -> np.ndarray:
    """A wall at 2-3 m (a ramp), 5 mm of range noise, 3% of pixels flickering out, the top rows never
    returning."""
    h, w = shape
    z = 2.0 + np.linspace(0, 1, w, dtype=np.float32)[None].repeat(h, 0)
    z = z + rng.normal(0, 0.005, shape).astype(np.float32)
    z[rng.random(shape) < 0.03] = 0
    z[:8] = 0
    return np.rint(z * SCALE).astype(np.uint16)


def _patched_recording(tmp_path: Path) -> Path:
    """A PNG folder of 10 frames of a still scene whose last has a patch read 4 cm near (the detector
    misses it; the scene does not)."""
    import cv2

    rng = np.random.default_rng(4)
    rec = tmp_path / "rec"
    rec.mkdir()
    frames = [_scene(rng) for _ in range(10)]
    frames[9][40:70, 30:80] = np.where(frames[9][40:70, 30:80] > 0, frames[9][40:70, 30:80] - 160, 0)
    for i, f in enumerate(frames):
        cv2.imwrite(str(rec / f"{i:03d}.png"), f)
    return rec


def _wall(rng: np.random.Generator, flicker: bool = False) -> np.ndarray:
    """A flat wall at 2.5 m, 5 mm of range noise, the top rows never returning; ``flicker``: a part of it
    drops out a fifth of the time."""
    z = 2.5 + rng.normal(0, 0.005, (96, 128))
    z[:8] = 0
    if flicker:
        z[20:80, 30:100][rng.random((60, 70)) < 0.2] = 0
    return np.rint(z * SCALE).astype(np.uint16)


def _learn(refs: Iterable[SceneReference], frames: Iterable[np.ndarray]) -> None:
    """Each clean frame, in order, judged by every reference and taken into it."""
    refs = list(refs)
    for f in frames:
        for ref in refs:
            ref.evidence(f)
            ref.add(f)


def _warm(ref: SceneReference, rng: np.random.Generator, n: int = 16) -> None:
    _learn([ref], (_scene(rng) for _ in range(n)))


def _show(loops: dict, frames: Iterable[np.ndarray]) -> None:
    """Each frame, in order, to every one of ``loops`` (the clean frames their scenes learn from)."""
    for f in frames:
        for loop in loops.values():
            loop.process(Capture(Frame("c", f), SCALE))


def _loops(net: FakeNet, repair: str, settings: dict) -> dict:
    """A still sensor's loop (the scene on) for each of ``settings``: name -> ``SceneSettings`` fields."""
    return {
        name: SensorLoop(
            net,
            make_controller("static", 30, 30),
            settings=RunSettings(repair=repair, scene=True, scene_settings=SceneSettings(**opts)),
        )
        for name, opts in settings.items()
    }


def test_a_patch_shifted_a_few_centimetres_is_evidence_and_the_scene_is_not():
    rng = np.random.default_rng(0)
    ref = SceneReference(SCALE)
    assert not ref.evidence(_scene(rng)).ready  # no scene yet: no evidence, not "clean"
    _warm(ref, rng)
    clean = ref.evidence(_scene(rng))
    assert clean.ready and clean.dense < QUIET and clean.share < 0.01
    hit = _scene(rng)
    patch = np.s_[40:70, 30:80]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.04 * SCALE), 0)  # 4 cm nearer, no dropouts
    ev = ref.evidence(hit)
    away = ~np.isin(np.arange(96), range(40 - SHIFT_PX, 70 + SHIFT_PX))  # beyond a shifted window's reach
    assert ev.mask[patch].mean() > 0.8 and ev.mask[away].mean() < 0.01
    assert ev.dense > 0.08


def test_a_surface_rippled_both_ways_is_evident_through_its_off_windows():
    """Alternate rows 2.2 cm nearer and farther: most pixels within their own tolerance and the windows'
    signed mean about right, so neither the deviations nor the shifted windows make it evident; most of each
    window reads over ``off_m`` off, so the off windows do, once the ring is full (with an ``off_area`` no
    frame reaches, they never flag). A clean frame has none."""
    rng = np.random.default_rng(5)
    refs = {area: _ref(off_area=area) for area in (OFF_AREA, NEVER)}
    young = SceneReference(SCALE)
    frames = [_scene(rng) for _ in range(16)]
    _learn(refs.values(), frames)
    _learn([young], frames[8:])  # warm, its ring short of full
    assert young.ready and young.count < young.settings.frames
    clean = _scene(rng)
    assert all(ref.evidence(clean).off < OFF_AREA for ref in refs.values())
    hit = _scene(rng)
    patch = np.s_[40:70, 30:80]
    sign = np.where(np.arange(30) % 2 == 0, -1, 1)[:, None]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] + sign * int(0.022 * SCALE), 0)
    on, off = (refs[a].evidence(hit.copy()) for a in (OFF_AREA, NEVER))
    assert on.fresh_dense < EVIDENT and on.fresh_shifted < 0.01  # nothing else makes it evident
    assert on.fresh_off > 20 * OFF_AREA and on.evident
    assert off.off == on.off and not off.evident
    assert young.evidence(hit.copy()).off == 0.0  # not against a ring short of its 16 frames


def test_a_surface_read_a_little_off_as_a_whole_is_evidence():
    """2 cm nearer (set G's median shift) is mostly inside each pixel's tolerance at 2-3 m, but a window's
    mean is 2 cm off: the shifted windows are fresh evidence, and a repaired frame takes the scene's depth
    there; a clean frame has none."""
    rng = np.random.default_rng(3)
    ref = SceneReference(SCALE)
    _warm(ref, rng)
    assert not ref.evidence(_scene(rng)).fresh.any()
    hit = _scene(rng)
    patch = np.s_[40:70, 30:80]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.02 * SCALE), 0)
    ev = ref.evidence(hit)
    assert ev.fresh[patch].mean() > 0.5 and not ev.fresh[:35].any()
    every = RunSettings(repair="all", scene=True, scene_repair=True)
    loop = SensorLoop(_NoRepair(), make_controller("static", 30, 30), settings=every)
    for _ in range(10):
        loop.process(Capture(Frame("c", _scene(rng)), SCALE))
    truth = _scene(rng)
    hit = truth.copy()
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.02 * SCALE), 0)
    res = loop.process(Capture(Frame("h", hit), SCALE))
    err = np.abs(res.depth[patch].astype(float) - truth[patch]) / SCALE
    assert np.median(err[truth[patch] > 0]) < 0.006  # back within the scene's noise


def test_lasting_change_becomes_the_scene_and_a_moved_camera_starts_it_again():
    rng = np.random.default_rng(1)
    ref = _ref(persist=5)
    _warm(ref, rng)
    moved = np.s_[20:40, 20:60]  # a chair put 30 cm in front of the wall, to stay (7% of the view)
    denses = []
    for _ in range(8):
        f = _scene(rng)
        f[moved] = np.where(f[moved] > 0, f[moved] - int(0.3 * SCALE), 0)
        ev = ref.evidence(f)
        denses.append(ev.dense)
    assert denses[0] > 0.05 and denses[-1] < QUIET
    for _ in range(3):  # the whole view changes (the camera was turned): no evidence of it, then a restart
        assert not ref.evidence((_scene(rng) // 2).astype(np.uint16)).ready
    assert not ref.ready


def test_fresh_shifted_windows_flag_a_frame_only_with_shift_area():
    """A patch 2 cm nearer deviates in windows, not pixel by pixel: its fresh shifted windows flag the frame
    (with an area no frame reaches they only mark pixels); clean frames stay unflagged either way, and
    the same patch again in the next frame reads as something that moved (not fresh)."""
    patch = np.s_[40:70, 30:80]
    for area in (NEVER, SHIPPED.shift_area):
        rng = np.random.default_rng(3)
        ref = _ref(shift_area=area, off_area=NEVER)  # the shifted windows alone
        _warm(ref, rng)
        for _ in range(20):
            ev = ref.evidence(f := _scene(rng))
            assert not ev.evident and ev.fresh_shifted < 0.003
            ref.add(f)
        hit = _scene(rng)
        hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.02 * SCALE), 0)
        ev = ref.evidence(hit)
        assert ev.usable and ev.dense < EVIDENT  # each pixel within its own tolerance
        assert ev.evident == (area < NEVER)
        if area < NEVER:
            assert ev.fresh_shifted > 0.05
            again = _scene(rng)
            again[patch] = np.where(again[patch] > 0, again[patch] - int(0.02 * SCALE), 0)
            assert not ref.evidence(again).evident  # in place a frame later: something that moved


def test_the_loop_flags_a_surface_read_a_centimetre_and_a_half_off_by_default():
    """The detector misses it (FakeNet flags nothing here), and no pixel deviates beyond its own tolerance;
    the scene's shifted windows find it, as shipped."""
    rng = np.random.default_rng(5)
    loop = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=True)
    )
    for _ in range(30):
        assert not loop.process(Capture(Frame("c", _scene(rng)), SCALE)).flagged
    hit = _scene(rng)
    hit[40:70, 30:80] = np.where(hit[40:70, 30:80] > 0, hit[40:70, 30:80] - int(0.015 * SCALE), 0)
    assert loop.process(Capture(Frame("h", hit), SCALE)).flagged
    assert not loop.process(Capture(Frame("c", _scene(rng)), SCALE)).flagged


def test_thin_lines_read_far_off_flag_a_frame_that_never_deviates_densely():
    """Lines 1 px wide every 8 rows, read at 60% of the depth, where the scene's returns agree: too thin for
    the dense evidence, but far off their pixels' clean range, which the sensor's flicker never is. The loop
    flags the frame as shipped (``far_area``), not with an area no frame reaches; clean frames stay
    unflagged."""
    loops = _loops(FakeNet(), "none", {"shipped": {}, None: {"far_area": NEVER}})
    rng = np.random.default_rng(9)
    for _ in range(20):
        f = _scene(rng)
        assert not any(loop.process(Capture(Frame("c", f), SCALE)).flagged for loop in loops.values())
    hit = _scene(rng)
    lines = hit[10::8, 20:110]
    hit[10::8, 20:110] = np.where(lines > 0, (lines * 0.6).astype(np.uint16), 0)
    shipped, off = (loop.process(Capture(Frame("h", hit), SCALE)) for loop in loops.values())
    assert shipped.flagged and not off.flagged
    assert not loops["shipped"].process(Capture(Frame("c", _scene(rng)), SCALE)).flagged


def test_strokes_one_pixel_wide_are_counted_over_every_return():
    """Short strokes one pixel wide, scattered, read at half the depth: the labeller's density filter drops
    them from the deviations; far-off returns are counted over every return, so they flag the frame."""
    loops = _loops(FakeNet(), "none", {"shipped": {}})
    rng = np.random.default_rng(10)
    for _ in range(20):
        f = _scene(rng)
        assert not any(loop.process(Capture(Frame("c", f), SCALE)).flagged for loop in loops.values())
    hit = _scene(rng)
    for y0 in range(12, 90, 14):
        for x0 in range(5, 120, 20):
            hit[y0, x0 : x0 + 3] = hit[y0, x0 : x0 + 3] // 2  # a stroke 3 px long, 1 px wide
    thin = loops["shipped"].process(Capture(Frame("h", hit), SCALE))
    ev = loops["shipped"]._reference.evidence(hit)
    assert thin.flagged and ev.dense < EVIDENT  # not dense: only the far-off returns flag it


def test_bad_settings_and_frames_are_refused():
    for bad in (
        {"far_area": 0},
        {"shift_area": 0},
        {"range_rate": 1.5},
        {"frames": 4, "warm": 8},
        {"tol": 1},
        {"shift_px": 17},  # its windows' counts would pass a byte's 255
        {"flicker_m": 0},
    ):
        with pytest.raises(ConfigError):
            SceneSettings(**bad)
    with pytest.raises(ConfigError):
        SceneSettings(warm="four")
    with pytest.raises(ConfigError):
        SceneReference(0)
    ref = SceneReference(SCALE)
    with pytest.raises(InputError):
        ref.add(np.zeros((4, 4), np.float32))
    ref.add(np.zeros((4, 4), np.uint16))
    with pytest.raises(InputError):
        ref.evidence(np.zeros((4, 5), np.uint16))


def test_the_loop_drops_a_flag_on_a_frame_that_matches_its_scene_and_keeps_a_real_one():
    """And says why (``Result.reason``), with every frame scored as d2sr detect scores them."""
    rng = np.random.default_rng(2)
    loop = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=True),
        exact_scores=True,
    )  # fmt: skip
    plain = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=False)
    )

    def frame(false_alarm: bool, hit: bool) -> Capture:
        f = _scene(rng)
        f[0, 0] = 1 if false_alarm or hit else 0  # what FakeNet flags
        if hit:
            f[40:70, 30:80] = np.where(f[40:70, 30:80] > 0, f[40:70, 30:80] - 160, 0)
        return Capture(Frame("f", f), SCALE)

    early = frame(True, False)  # before the scene is known: the detector alone decides
    first = loop.process(early)
    assert first.flagged and first.reason == "detector" and plain.process(early).flagged
    for _ in range(12):
        quiet = loop.process(frame(False, False))
        assert not quiet.flagged and quiet.reason == ""
    false_alarm = frame(True, False)
    cleared = loop.process(false_alarm)
    assert not cleared.flagged and cleared.reason == "cleared by scene"  # why interfered is 0 at score 1
    kept = plain.process(false_alarm)
    assert kept.flagged and kept.reason == "detector"
    both = loop.process(frame(True, True))
    assert both.flagged and both.reason == "detector+scene"
    assert not loop.process(frame(False, False)).flagged
    missed = frame(False, True)
    missed.frame.depth[0, 0] = 0  # the detector misses it; the fresh patch against the scene does not
    found = loop.process(missed)
    assert found.flagged and found.reason == "scene" and not plain.process(missed).flagged


def test_a_frame_the_scene_decides_alone_is_not_scored_and_keeps_its_verdict():
    """Once the scene is known, a frame that matches it (clean whatever the detector says) or deviates in
    fresh patches (interfered whatever it says) costs no detector run and reads NaN; with ``exact_scores``
    every frame is scored; the verdicts are the same either way."""
    rng = np.random.default_rng(4)
    nets = FakeNet(), FakeNet()
    fast, exact = (
        SensorLoop(
            n,
            make_controller("static", 30, 30),
            exact_scores=e,
            settings=RunSettings(repair="none", scene=True),
        )
        for n, e in zip(nets, (False, True), strict=True)
    )
    frames = [_scene(rng) for _ in range(10)]
    frames[6][0, 0] = 1  # a false alarm on a frame that matches its scene
    patch = frames[8][40:70, 30:80]
    patch[patch > 0] -= 160  # a patch 4 cm nearer that the detector misses
    runs = [[loop.process(Capture(Frame("f", f.copy()), SCALE)) for f in frames] for loop in (fast, exact)]
    assert [r.flagged for r in runs[0]] == [r.flagged for r in runs[1]] == [False] * 8 + [True, False]
    # Scored until the scene is warm (4 frames) and one frame has shown it still (the stillness gate).
    assert len(nets[1].before) == 10 and len(nets[0].before) == 5
    assert all(np.isnan(r.score) for r in runs[0][5:]) and not any(np.isnan(r.score) for r in runs[1])


def test_fresh_evidence_is_worked_out_only_where_it_can_flag():
    """``Evidence.evident`` is ``fresh_dense >= EVIDENT``; on a frame that matches its scene (``dense``, the
    bound, below it) the fresh deviations are not worked out unless read."""
    rng = np.random.default_rng(5)
    ref = SceneReference(SCALE)
    _warm(ref, rng)
    for hit in (False, True):
        f = _scene(rng)
        if hit:
            patch = f[40:70, 30:80]
            patch[patch > 0] -= 160
        ev = ref.evidence(f)
        assert ev.parts is not None
        calls, explain = [], ev.parts.explain
        ev.parts.explain = lambda calls=calls, explain=explain: calls.append(1) or explain()
        assert ev.evident == hit and len(calls) == hit
        assert (ev.fresh_dense >= EVIDENT) == hit and len(calls) == 1  # read: worked out, once


def test_something_that_moves_is_not_fresh_evidence_but_a_new_patch_is():
    """A box 40 cm in front of the wall slides 6 px a frame: it deviates, but the frame before's deviations
    explain it (something moved). A patch 3 cm off where nothing deviated a frame before is fresh. The first
    frame judged against a new scene has nothing before it: nothing is fresh."""
    rng = np.random.default_rng(3)
    ref = SceneReference(SCALE)
    first = None
    for _ in range(16):
        ev = ref.evidence(f := _scene(rng))
        first = ev if ev.ready and first is None else first
        ref.add(f)
    assert first is not None and not first.fresh.any()
    for k in range(6):
        f = _scene(rng)
        box = np.s_[30:60, 10 + 6 * k : 40 + 6 * k]  # 8% of the view
        f[box] = np.where(f[box] > 0, f[box] - int(0.4 * SCALE), 0)
        ev = ref.evidence(f)
        assert ev.dense > 0.05
        if k > 0:
            assert ev.fresh_dense < 0.1 * ev.dense, (k, ev.fresh_dense, ev.dense)
    f = _scene(rng)
    patch = np.s_[10:30, 90:120]
    f[patch] = np.where(f[patch] > 0, f[patch] - int(0.04 * SCALE), 0)
    ev = ref.evidence(f)
    assert ev.mask[patch].mean() > 0.8 and ev.fresh[patch].mean() > 0.98 * ev.mask[patch].mean()
    assert ev.fresh_dense > 0.03


def test_run_on_a_recording_takes_the_scene(tmp_path):
    """``d2sr run REC --scene`` (``run_recording(scene=True)``): the patch the detector misses is logged as
    flagged, and the run's settings say the scene was used; without it, the frame passes."""
    import csv

    from d2sr.frames import open_frames
    from d2sr.jobs.session import Recording, run_recording

    rec = _patched_recording(tmp_path)
    flags = {}
    # The share of frames the scene weighed: cold (a live sensor's start), not the first 5 (4 build it, the
    # 5th shows it still); primed on the frames ahead, as recover primes it (the default), every one.
    for scene, prime, weighed in ((False, 32, None), (True, 0, 0.5), (True, 32, 1.0)):
        out = tmp_path / f"out{scene}{prime}"
        recording = Recording(open_frames(rec), SCALE, "rec")
        settings = RunSettings(repair="none", scene=scene, prime=prime)
        summary = run_recording(FakeNet(), recording, out, settings, LoopSettings(controller="robust"))
        assert summary["settings"]["scene"] is scene
        assert summary["all"].get("scene_used") == weighed
        rows = list(csv.DictReader((out / "log.csv").open()))
        flags[scene, prime] = [int(r["flagged"]) for r in rows]
    assert flags[False, 32] == [0] * 10 and flags[True, 0] == flags[True, 32] == [0] * 9 + [1]


class _NoRepair(FakeNet):
    def recover(self, metres, previous=None):  # a model that masks nothing: only the scene repairs
        return metres.copy(), np.zeros(metres.shape, bool)


def test_the_scene_repairs_a_shifted_patch_where_it_is_trusted_and_leaves_clean_frames_alone():
    """``scene_repair`` (on by default): a patch read 4 cm near, which the detector and the model both miss,
    is put back to within the scene's noise where the scene is trusted; a clean frame comes out bit for bit;
    with it off, the patch stays."""
    rng = np.random.default_rng(5)
    on = SensorLoop(
        _NoRepair(), make_controller("static", 30, 30), settings=RunSettings(repair="flagged", scene=True)
    )
    off = SensorLoop(
        _NoRepair(),
        make_controller("static", 30, 30),
        settings=RunSettings(repair="flagged", scene=True, scene_repair=False),
    )
    for _ in range(10):
        f = _scene(rng)
        for loop in (on, off):
            res = loop.process(Capture(Frame("c", f), SCALE))
            assert np.array_equal(res.depth, f) and not res.mask.any()
    truth = _scene(rng)
    hit = truth.copy()
    patch = np.s_[40:70, 30:80]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.04 * SCALE), 0)
    fixed, kept = (loop.process(Capture(Frame("h", hit), SCALE)) for loop in (on, off))
    assert fixed.flagged and kept.flagged and np.array_equal(kept.depth, hit)
    err = np.abs(fixed.depth[patch].astype(float) - truth[patch]) / SCALE
    returned = truth[patch] > 0
    assert fixed.mask[patch][returned].mean() > 0.8 and np.median(err[returned & fixed.mask[patch]]) < 0.01
    # Outside the patch: nothing beyond a shifted window's reach changes; within it, a few returns that
    # deviate as the patch does, each to the scene's own depth (its median there).
    assert not fixed.mask[: 40 - SHIFT_PX].any()
    changed = fixed.depth[:40] != hit[:40]
    assert on._reference is not None and on._reference._stats is not None
    median = on._reference._stats.nz_median[:40] * SCALE
    assert changed.mean() < 0.02 and np.abs(fixed.depth[:40][changed] - median[changed]).max() <= 1


def test_the_scene_repairs_a_return_where_it_returns_most_of_the_time():
    """A region that returns in about 70% of the clean frames at agreeing depths: a 4 cm shift of its
    returns is put back by the scene (trusted from ``range_rate``); the region's dropouts stay."""
    flicker = np.s_[40:70, 30:55]  # the left half of the patch below flickers

    def scene(rng: np.random.Generator) -> np.ndarray:
        f = _scene(rng)
        f[flicker] = np.where(rng.random(f[flicker].shape) < 0.3, 0, f[flicker])
        return f

    loops = _loops(_NoRepair(), "flagged", {None: {}})
    rng = np.random.default_rng(8)
    _show(loops, (scene(rng) for _ in range(20)))
    truth = scene(rng)
    hit = truth.copy()
    patch = np.s_[40:70, 30:80]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.04 * SCALE), 0)
    shipped = loops[None].process(Capture(Frame("h", hit), SCALE))
    back = truth[flicker] > 0
    err = np.abs(shipped.depth[flicker].astype(float) - truth[flicker])[back] / SCALE
    assert shipped.flagged and np.median(err) < 0.01
    assert (shipped.depth[flicker] != hit[flicker])[back].mean() > 0.8
    assert (shipped.depth[flicker][~back] > 0).mean() < 0.1  # a dropout: only where it nearly always returns


def test_reliable_fill_repairs_sparser_patches_only_where_the_scene_nearly_always_returns():
    """A region where a third of the returns read 10% near (fresh deviations amid about a third of their 9x9
    neighbours, under ``HALF``) takes the scene's depth where the scene nearly always returns; where the
    scene returns in only about 70% of its frames it is left to the model; a clean frame gets no fill."""
    flicker = np.s_[40:70, 90:120]

    def scene(rng: np.random.Generator) -> np.ndarray:
        f = _scene(rng)
        f[flicker] = np.where(rng.random(f[flicker].shape) < 0.3, 0, f[flicker])
        return f

    # Far-off returns never flag here: a return read 10% near is far off, and their fill would take it.
    refs = {True: _ref(far_area=NEVER)}
    rng = np.random.default_rng(11)
    _learn(refs.values(), (scene(rng) for _ in range(16)))
    clean = scene(rng)
    for ref in refs.values():
        assert not ref.repair(ref.evidence(clean)).fill.any()
    truth = scene(rng)
    hit = truth.copy()
    region = np.s_[40:70, 20:120]
    some = (hit[region] > 0) & (rng.random(hit[region].shape) < 1 / 3)
    hit[region] = np.where(some, (hit[region] * 0.9).astype(np.uint16), hit[region])
    on = refs[True].repair(refs[True].evidence(hit))
    reliable = np.s_[40:70, 20:90]
    moved = (hit != truth)[reliable]
    assert on.fill[reliable][moved].mean() > 0.8
    err = np.abs(on.depth[reliable][on.fill[reliable]] - truth[reliable][on.fill[reliable]] / SCALE)
    assert np.median(err) < 0.01  # the scene's own depth, within its noise
    # Where the scene returns about 70% of the time (only the few pixels that happened to return in 90% of
    # its frames count as nearly always): the model's.
    hit_f = (hit != truth)[flicker]
    assert on.fill[flicker][hit_f].mean() < 0.2


def test_far_fill_takes_the_scene_for_far_off_returns_only_where_they_flag_the_frame():
    """Scattered strokes one pixel wide read at half their depth, in a frame whose far-off returns cover
    ``far_area`` of the scene, take the scene's depth (also where the scene returns only 70% of the time),
    which the fill in patches (with an area no frame reaches) never gives them; a few far-off returns
    alone (the sensor's own flying returns) and a clean frame are left as they are."""
    flicker = np.s_[40:70, 90:120]

    def scene(rng: np.random.Generator) -> np.ndarray:
        f = _scene(rng)
        f[flicker] = np.where(rng.random(f[flicker].shape) < 0.3, 0, f[flicker])
        return f

    refs = {False: _ref(far_area=NEVER), True: _ref()}
    rng = np.random.default_rng(12)
    _learn(refs.values(), (scene(rng) for _ in range(16)))
    for ref in refs.values():
        assert not ref.repair(ref.evidence(scene(rng))).fill.any()
    truth = scene(rng)
    hit = truth.copy()
    strokes = np.zeros(hit.shape, bool)
    for y0 in range(12, 90, 7):
        for x0 in range(3, 124, 9):
            strokes[y0, x0 : x0 + 3] = True
    strokes &= truth > 0
    hit[strokes] = truth[strokes] // 2
    off, on = (ref.repair(ref.evidence(hit)) for ref in refs.values())
    assert off.fill[strokes].mean() < 0.1 and on.fill[strokes].mean() > 0.9
    assert on.fill[flicker][strokes[flicker]].mean() > 0.9  # where the scene returns 70% of the time too
    err = np.abs(on.depth[strokes & on.fill] - truth[strokes & on.fill] / SCALE)
    assert np.median(err) < 0.01 and not on.fill[~strokes].any()
    few = truth.copy()
    few[50, 60:63] = truth[50, 60:63] // 2  # three flying returns: under ``far_area``
    for ref in refs.values():
        ev = ref.evidence(few)
        assert not ev.far_evident and not ref.repair(ev).fill.any()


def test_rare_fill_takes_the_scene_for_far_off_patches_where_it_seldom_returns():
    """In a frame whose far-off returns flag it, a patch read at half its depth where the scene returns only a
    third of the time takes the scene's depth, as neither the far-off returns' fill nor the fill in patches
    gives it; a few stray returns there read metres off (the sensor's own) are left as they are."""
    seldom = np.s_[40:80, 60:120]

    def scene(rng: np.random.Generator) -> np.ndarray:
        f = _scene(rng)
        f[seldom] = np.where(rng.random(f[seldom].shape) < 2 / 3, 0, f[seldom])
        return f

    refs = {True: _ref()}
    rng = np.random.default_rng(13)
    _learn(refs.values(), (scene(rng) for _ in range(16)))
    truth = scene(rng)
    hit = truth.copy()
    hit[12:30:6, 10:50] //= 2  # strokes where the scene always returns: the frame's far-off evidence
    patch = np.zeros(hit.shape, bool)
    patch[45:65, 70:95] = True
    patch &= truth > 0
    hit[patch] = truth[patch] // 2
    stray = np.zeros(hit.shape, bool)
    stray[75, 110:112] = True
    stray &= truth > 0
    hit[stray] = truth[stray] // 3
    on = refs[True].repair(refs[True].evidence(hit))
    # The far-off fill takes the few pixels of the patch that happened to return in half the scene's frames; a
    # quarter of a 9x9 neighbourhood where a third returns asks for nearly all of it: the patch's inside
    inside = np.zeros_like(patch)
    inside[49:61, 74:91] = True
    inside &= patch
    assert on.fill[inside].mean() > 0.9 and on.fill[patch].mean() > 0.5
    err = np.abs(on.depth[patch & on.fill] - truth[patch & on.fill] / SCALE)
    assert np.median(err) < 0.01
    assert not on.fill[stray].any()
    for ref in refs.values():  # a clean frame: nothing
        assert not ref.repair(ref.evidence(scene(rng))).fill.any()


def test_offset_fill_puts_a_shifted_surface_back_within_its_own_noise():
    """A patch of a noisy wall (7 mm of range noise) read 3 cm near, in a frame its shifted windows flag, gets
    each pixel's own depth less the window's offset: nearly all of it comes back within 1 cm of the clean
    frame, more than the scene's median would bring back, since that is a median's distance from each
    pixel's own reading. A clean frame is left as it is."""
    shape = (96, 128)

    def wall(rng: np.random.Generator) -> np.ndarray:
        z = 2.0 + np.linspace(0, 1, shape[1])[None].repeat(shape[0], 0) + rng.normal(0, 0.007, shape)
        z[:8] = 0
        return np.rint(z * SCALE).astype(np.uint16)

    refs = {True: _ref()}
    rng = np.random.default_rng(21)
    _learn(refs.values(), (wall(rng) for _ in range(16)))
    for ref in refs.values():  # a clean frame: nothing
        assert not ref.repair(ref.evidence(wall(rng))).fill.any()
    truth = wall(rng)
    hit = truth.copy()
    patch = np.s_[30:80, 20:90]
    hit[patch] -= np.uint16(0.03 * SCALE)
    back = {}
    for k, ref in refs.items():
        ev = ref.evidence(hit)
        assert ev.shift_evident
        r = ref.repair(ev)
        out = np.where(r.fill, r.depth, hit / SCALE)  # the model's pixels aside: the input, for both
        back[k] = float((np.abs(out - truth / SCALE)[patch] <= 0.01).mean())
        assert not r.fill[:28].any() and not r.fill[82:].any()  # rows the shift leaves alone
        median = ref._stats.nz_median
        back[False] = float((np.abs(median - truth / SCALE)[patch] <= 0.01).mean())
    assert back[True] > 0.95 and back[True] > back[False] + 0.1


class _Doubles(FakeNet):
    def recover(
        self, metres, previous=None
    ):  # masks everything; reads a return under 1.6 m at twice its depth
        return np.where(metres < 1.6, 2 * metres, metres).astype(np.float32), np.ones(metres.shape, bool)


def test_the_scene_keeps_a_seldom_seen_return_only_near_its_depth():
    """Where the scene seldom returns (a flickering region), a return near the depth it did return at is
    kept from the model (``keep``); one read far off is left to the model."""
    rare = np.s_[20:40, 10:40]

    def scene(rng: np.random.Generator) -> np.ndarray:
        f = _scene(rng)
        f[rare] = np.where(rng.random(f[rare].shape) < 0.6, 0, f[rare])  # returns 40% of the time
        return f

    loops = _loops(_Doubles(), "all", {True: {}})
    rng = np.random.default_rng(11)
    _show(loops, (scene(rng) for _ in range(20)))
    hit = scene(rng)
    hit[rare] = np.where(hit[rare] > 0, hit[rare], 0)
    far = np.zeros(hit.shape, bool)
    far[25, 15:35] = True  # a stroke read at half its pixels' depth, where the scene seldom returns
    truth = _scene(np.random.default_rng(11))[far]
    hit[far] = np.where(truth > 0, truth // 2, 0)
    near_out = loops[True].process(Capture(Frame("h", hit), SCALE))
    returned = hit[rare] > 0
    kept_near = (near_out.depth[rare] == hit[rare])[returned & ~far[rare]]
    assert kept_near.mean() > 0.9  # returns near their depth: kept from the model
    assert (near_out.depth[far] == hit[far]).mean() < 0.5  # the far-off stroke: the model's


class _Guesses(FakeNet):
    def recover(self, metres, previous=None):  # masks everything, and guesses 1.5 m farther than it reads
        return np.where(metres > 0, metres + 1.5, 3.0).astype(np.float32), np.ones(metres.shape, bool)


def test_the_scene_keeps_a_model_off_the_pixels_that_read_as_the_scene():
    """``scene_repair`` with ``repair="all"``: a model that would move every pixel moves none that reads
    within its scene's range, on a clean frame or around a shifted patch; the patch's trusted pixels take
    the scene's depth; the clean frame's dropouts, with no return moved, are the sensor's own and stay.
    Without ``scene_repair`` the model's guess stands (the guard alone lets a 1.5 m move through where no
    neighbour is trusted)."""
    rng = np.random.default_rng(7)
    loops = [
        SensorLoop(
            _Guesses(),
            make_controller("static", 30, 30),
            settings=RunSettings(repair="all", scene=True, scene_repair=on),
        )
        for on in (True, False)
    ]
    for _ in range(10):
        f = _scene(rng)
        for loop in loops:
            loop.process(Capture(Frame("c", f), SCALE))
    clean = _scene(rng)
    on, off = (loop.process(Capture(Frame("c", clean), SCALE)) for loop in loops)
    returned = clean > 0
    assert np.array_equal(on.depth[returned], clean[returned]) and not on.mask[returned].any()
    assert (off.depth[returned] != clean[returned]).mean() > 0.9
    assert np.array_equal(on.depth, clean)  # its dropouts too: holes alone are the sensor's own
    assert (off.depth[~returned] > 0).all()  # where the model moves returns, it fills the holes with them
    truth = _scene(rng)
    hit = truth.copy()
    patch = np.s_[40:70, 30:80]
    hit[patch] = np.where(hit[patch] > 0, hit[patch] - int(0.04 * SCALE), 0)
    on = loops[0].process(Capture(Frame("h", hit), SCALE))
    outside = np.ones(hit.shape, bool)
    outside[30:80, 20:90] = False  # the patch and a margin around it
    assert np.array_equal(on.depth[outside & (hit > 0)], hit[outside & (hit > 0)])
    err = np.abs(on.depth[patch].astype(float) - truth[patch]) / SCALE
    assert np.median(err[truth[patch] > 0]) < 0.01


def test_recover_cli_takes_the_scene_repair_and_refuses_it_alone(tmp_path):
    """``d2sr recover --repair all --scene --scene-repair`` puts a 4 cm patch back on real weights; without
    the scene (``--no-scene``) it is a one-line error and nothing is written."""
    import cv2

    from helpers import d2sr_inprocess

    rng = np.random.default_rng(6)
    rec = tmp_path / "rec"
    rec.mkdir()
    frames = [_scene(rng, (96, 128)) for _ in range(12)]
    truth = frames[11].copy()
    frames[11][40:70, 30:80] = np.where(truth[40:70, 30:80] > 0, truth[40:70, 30:80] - 160, 0)
    for i, f in enumerate(frames):
        cv2.imwrite(str(rec / f"{i:03d}.png"), f)
    code, _, err = d2sr_inprocess("recover", str(rec), "--out", str(tmp_path / "a"), "--depth-scale", "4000",
                                  "--repair", "all", "--no-scene", "--scene-repair")  # fmt: skip
    assert code == 2 and "needs the scene" in err and "--scene-repair" in err
    assert not (tmp_path / "a").exists()
    code, _, err = d2sr_inprocess("recover", str(rec), "--out", str(tmp_path / "b"), "--depth-scale", "4000",
                                  "--repair", "all", "--scene", "--scene-repair")  # fmt: skip
    assert code == 0, err
    out = cv2.imread(str(tmp_path / "b" / "011.png"), cv2.IMREAD_UNCHANGED)
    ok = truth[40:70, 30:80] > 0
    err_m = np.abs(out[40:70, 30:80].astype(float) - truth[40:70, 30:80])[ok] / SCALE
    assert np.median(err_m) < 0.01  # put back within the scene's noise (it was 4 cm off)
    # Without --repair all the scene repairs by default (the frame is flagged by the scene's evidence);
    # --no-scene-repair leaves the patch to the model.
    runs = {"c": (), "d": ("--no-scene-repair",)}
    for name, extra in runs.items():
        out_dir = str(tmp_path / name)
        code, _, err = d2sr_inprocess("recover", str(rec), "--out", out_dir, "--depth-scale", "4000", *extra)
        assert code == 0, err
    by_default, without = (cv2.imread(str(tmp_path / n / "011.png"), cv2.IMREAD_UNCHANGED) for n in runs)
    err_m = np.abs(by_default[40:70, 30:80].astype(float) - truth[40:70, 30:80])[ok] / SCALE
    assert np.median(err_m) < 0.01
    err_m = np.abs(without[40:70, 30:80].astype(float) - truth[40:70, 30:80])[ok] / SCALE
    assert np.median(err_m) > 0.03


def _panned(rng: np.random.Generator, k: int, patch: bool) -> np.ndarray:
    """A hand-held sensor panning 3 px a frame across bars 0.5 m apart (a fifth to a third of its view
    deviates from any scene it built), with a box 30 cm nearer somewhere on every ``patch`` frame."""
    h, w = 96, 128
    z = 2.5 + 0.5 * (((np.arange(w) + 3 * k) // 32) % 2)[None].repeat(h, 0).astype(np.float32)
    z = z + rng.normal(0, 0.005, (h, w)).astype(np.float32)
    if patch:
        r, c = rng.integers(10, 60), rng.integers(0, 90)
        z[r : r + 30, c : c + 30] -= 0.3
    z[rng.random((h, w)) < 0.03] = 0
    return np.rint(z * SCALE).astype(np.uint16)


def test_a_moving_sensor_s_scene_decides_nothing():
    """The stillness gate: on a panning sensor no frame the scene took as clean matched it within
    ``STILL_SHARE``, so its evidence is never usable and the loop's verdicts are the detector's alone.
    Ungated (``still_share=None``) the same scene calls frames interfered."""
    evident = {}
    for gate in (None, STILL_SHARE):
        rng = np.random.default_rng(7)
        ref = _ref(still_share=gate, rest=0)  # the gate alone, without the rests
        seen = []
        for k in range(60):
            ev = ref.evidence(f := _panned(rng, k, k % 3 == 2))
            seen.append(ev)
            if not ev.evident:
                ref.add(f)
        evident[gate] = sum(ev.evident for ev in seen)
        if gate is not None:
            assert any(ev.ready for ev in seen) and not any(ev.usable for ev in seen) and not ref.still
    assert evident[None] >= 3 and evident[STILL_SHARE] == 0
    rng = np.random.default_rng(7)
    frames = [_panned(rng, k, k % 3 == 2) for k in range(60)]
    loop = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=True)
    )
    assert not any(loop.process(Capture(Frame(f"{i}", f), SCALE)).flagged for i, f in enumerate(frames))


def test_a_still_sensor_s_scene_is_used_once_a_frame_has_matched_it():
    """Warm (``warm`` frames) is not enough: the first frame judged against the scene and taken as clean
    shows the sensor still; a scene that starts again starts the gate again."""
    rng = np.random.default_rng(8)
    ref = SceneReference(SCALE)
    for _ in range(4):
        ref.evidence(f := _scene(rng))
        ref.add(f)
    first = ref.evidence(f := _scene(rng))
    assert first.ready and not first.usable and not ref.still
    ref.add(f)
    assert ref.still and ref.evidence(_scene(rng)).usable
    ref.reset()
    assert not ref.still
    with pytest.raises(ConfigError):
        SceneSettings(still_share=0)


def test_the_commands_judge_the_scene_by_default_and_no_scene_leaves_the_detector_alone(tmp_path):
    """``d2sr detect REC`` weighs the shipped detector against the sensor's scene unless ``--no-scene``: a
    patch read 4 cm near on the last frame, which the detector misses, is flagged only with the scene, and
    ``d2sr.Pipeline`` judges the scene unless ``scene=False``."""
    import csv

    import d2sr
    from d2sr.frames import open_frames
    from helpers import d2sr_inprocess

    rec = _patched_recording(tmp_path)
    flags, said = {}, {}
    for name, extra in (("default", ()), ("alone", ("--no-scene",))):
        out = tmp_path / f"{name}.csv"
        code, said[name], err = d2sr_inprocess(
            "detect", str(rec), "--depth-scale", "4000", "--out", str(out), *extra
        )
        assert code == 0, err
        flags[name] = [int(r["interfered"]) for r in csv.DictReader(out.open())]
    assert flags["default"] == [0] * 9 + [1] and flags["alone"] == [0] * 10
    # the summary line says how many verdicts the scene weighed: every one, as the recording's frames ahead
    # built it first (``--prime``); from the 6th with --prime 0, as a live sensor starts
    assert "1 of 10 frames flagged as interfered; 10 also judged against the sensor's own" in said["default"]
    assert "0 of 10 frames flagged as interfered ->" in said["alone"]
    code, cold, err = d2sr_inprocess(
        "detect", str(rec), "--depth-scale", "4000", "--out", str(tmp_path / "cold.csv"), "--prime", "0"
    )
    assert code == 0 and "1 of 10 frames flagged as interfered; 5 also judged against" in cold, err
    # Each result says whether the scene weighed it: from the 6th frame (4 build it, the 5th shows it still)
    frames = [f.depth for f in open_frames(rec)]
    judged = [d2sr.Pipeline(depth_scale=4000, scene=s) for s in (True, False)]
    weighed = [[p.process(f).scene for f in frames] for p in judged]
    assert weighed[0] == [False] * 5 + [True] * 5 and weighed[1] == [None] * 10


def test_a_primed_loop_judges_a_recording_s_first_frames_against_its_scene():
    """A recording whose frames 1 and 3 have a patch read 4 cm near that the detector misses: cold (a live
    sensor) both come before the scene is built and pass; primed on the frames ahead (``SensorLoop.primed``)
    both are flagged, and the scene weighs every verdict. Priming leaves nothing else behind: the period,
    the controller's window and the frames the models remember are those of a loop that saw nothing."""
    rng = np.random.default_rng(6)
    frames = [_scene(rng) for _ in range(12)]
    for k in (1, 3):
        patch = frames[k][40:70, 30:80]
        patch[patch > 0] -= 160
    runs = {}
    for prime in (0, 32):
        net = FakeNet(frames=2)  # a temporal detector: it is given the frame before
        loop = SensorLoop(
            net,
            make_controller("robust", 30, 6, seed=0),
            exact_scores=True,
            settings=RunSettings(repair="none", scene=True),
        )
        caps = loop.primed((Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames)), prime)
        first = next(caps)
        assert loop.period == 0 and loop.controller.offset == make_controller("robust", 30, 6, seed=0).offset
        before = len(net.before)
        res = [loop.process(first)] + [loop.process(c) for c in caps]
        runs[prime] = res
        assert net.before[before] is None and net.before[before + 1] is not None  # frame 0 has none before
        assert len(net.before) == 12 + (11 if prime else 0)  # primed on frames 11 to 1
        assert [r.capture.name for r in res] == [str(i) for i in range(12)] and loop.period == 2
    flagged = {p: [i for i, r in enumerate(res) if r.flagged] for p, res in runs.items()}
    assert flagged == {0: [], 32: [1, 3]}
    assert all(r.scene for r in runs[32]) and not any(r.scene for r in runs[0][:5])
    loop = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=True)
    )
    with pytest.raises(ConfigError):
        loop.primed([], -1)
    alone = SensorLoop(
        FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=False)
    )  # no scene: nothing read
    caps = [Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames)]
    assert [c.name for c in alone.primed(iter(caps))] == [c.name for c in caps]


def test_a_scene_that_keeps_moving_rests_longer_each_time_until_its_gate_opens():
    """After a restart because the view changed, the scene judges and keeps nothing for ``REST`` frames,
    twice as long after the next such restart; a still view that opens the gate resets the count."""
    rng = np.random.default_rng(9)
    ref = _ref(rest=3)
    for _ in range(6):
        ref.evidence(f := _scene(rng))
        ref.add(f)
    assert ref.still

    def moved(k: int) -> np.ndarray:  # another view: the wall 40 cm nearer
        return (_scene(rng).astype(np.int64) - (k + 1) * 1600).clip(0).astype(np.uint16)

    rests = []
    for _ in range(2):
        for k in range(3):  # three frames of another view: the scene starts again
            ref.evidence(moved(k))
        n = 0
        while not ref.evidence(f := _scene(rng)).ready and n < 40:
            ref.add(f)  # resting: kept nothing
            n += 1
        rests.append(n)
    # resting 3, then 6 frames; then 4 frames build it (the 4th evidence is the first ready one)
    assert rests == [3 + 4, 6 + 4], rests
    assert _ref(rest=0).settings.rest == 0
    with pytest.raises(ConfigError):
        SceneSettings(rest=-1)


def test_shifted_windows_are_worked_out_over_pixels_that_return_70_percent_of_the_time():
    """Where a wall's returns drop out a fifth of the time, a patch read 3 cm near is found by the shifted
    windows as shipped (``SHIFT_RATE``: pixels returning 70% of the time), not over steady pixels alone
    (``TRUST_RATE``, as before sealed set V)."""
    rng = np.random.default_rng(12)
    clean, now = [_wall(rng, flicker=True) for _ in range(16)], _wall(rng, flicker=True)
    now[30:70, 40:90] = np.where(now[30:70, 40:90] > 0, now[30:70, 40:90] - int(0.03 * SCALE), 0)
    shifted = {}
    for rate in (TRUST_RATE, SHIFT_RATE):
        ref = _ref(shift_rate=rate)
        _learn([ref], clean)
        shifted[rate] = ref.evidence(now).shifted
    assert SHIFT_RATE < TRUST_RATE
    assert shifted[TRUST_RATE] < 0.01 <= 0.08 < shifted[SHIFT_RATE], shifted
    with pytest.raises(ConfigError):
        SceneSettings(shift_rate=0)


def test_a_primed_scene_is_kept_only_where_the_sensor_held_still():
    """``SensorLoop.prime`` keeps the scene of a sensor that held still over the frames ahead; that of a
    camera whose view keeps changing is dropped (``SceneReference.settled``), so the recording starts cold
    as a live sensor does."""
    rng = np.random.default_rng(13)
    still = [_scene(rng) for _ in range(20)]
    moving = [np.roll(_scene(rng), 9 * i, axis=1) for i in range(20)]  # the view pans 9 px a frame

    def primed(frames: list[np.ndarray]) -> SensorLoop:
        loop = SensorLoop(
            FakeNet(), make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=True)
        )
        loop.prime([Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames)])
        return loop

    kept = primed(still)._reference
    assert kept is not None and kept.settled
    assert primed(moving)._reference is None


@pytest.mark.parametrize("stored", [False, True])
def test_a_deferred_scene_repair_reads_the_scene_as_it_was_when_asked_for(stored):
    """``repair_later`` (the loop works it out in ``finish``, on a worker, while later frames are judged):
    called after the reference has taken in more clean frames (new statistics, stripe by stripe) and a
    lasting change, it gives bit for bit what ``repair`` gave at once, though the reference's own
    statistics have moved; a stored scene's surface test too."""
    from d2sr.scene.stored import learn_scene

    rng = np.random.default_rng(8)
    frames = [_scene(rng) for _ in range(16)]

    def reference() -> SceneReference:
        if stored:
            return SceneReference.from_stored(learn_scene(lambda: iter(frames), SCALE, "s", 16))
        ref = _ref()
        _learn([ref], frames)
        return ref

    hit = _scene(rng)
    hit[40:70, 30:80] = np.where(hit[40:70, 30:80] > 0, hit[40:70, 30:80] - int(0.04 * SCALE), 0)
    now_ref, later_ref = reference(), reference()
    for ref in (now_ref, later_ref):
        ref.evidence(_scene(rng))  # the frame before: what explains the next one's deviations
    now = now_ref.repair(now_ref.evidence(hit))
    later = later_ref.repair_later(later_ref.evidence(hit))
    assert later_ref._stats is not None
    before = later_ref._stats.nz_median.copy()
    moved = [_scene(rng) for _ in range(SHIPPED.persist + 2)]
    for f in moved:  # a box 10 cm farther from then on: the scene after ``persist`` frames
        f[10:40, 90:120] = np.where(f[10:40, 90:120] > 0, f[10:40, 90:120] + int(0.1 * SCALE), 0)
    _learn([later_ref], moved)
    assert not np.array_equal(later_ref._stats.nz_median, before)
    got = later()
    assert now.fill.any()
    for a, b in zip(now, got, strict=True):
        assert np.array_equal(a, b)


def _full_wall_scene(seed: int, part: int = 0, **settings: object) -> SceneReference:
    """A live reference whose ring is full of a wall; ``part``: metres x 4000 the patch reads off in every
    other of those frames (interference the detector passed, repeating at one place)."""
    rng = np.random.default_rng(seed)
    ref = _ref(**settings)
    frames = [_wall(rng) for _ in range(SHIPPED.frames)]
    for f in frames[1::2]:
        f[40:60, 30:70] += part
    _learn([ref], frames)
    assert ref.count == SHIPPED.frames
    return ref


def _patched(frame: np.ndarray, off: float) -> np.ndarray:
    """``frame`` with its patch read ``off`` metres off."""
    frame[40:60, 30:70] = (frame[40:60, 30:70] + np.int32(off * SCALE)).astype(np.uint16)
    return frame


def _patch_fresh(ref: SceneReference, seed: int, offsets: list[float]) -> list[float]:
    """Each frame's patch read off by ``offsets`` (metres) in turn: the share of it that is fresh."""
    rng = np.random.default_rng(seed)
    return [float(ref.evidence(_patched(_wall(rng), off)).fresh[40:60, 30:70].mean()) for off in offsets]


def test_a_full_live_scene_keeps_a_surface_whose_offset_flickers_fresh_and_one_that_rests_explained():
    """A CW-ToF neighbour reads the same surface a few centimetres off by an amount that changes frame to
    frame: against a live scene whose ring is full, nothing that moved explains it (``flicker_m``). A thing
    resting on the surface reads the same each frame: after its first, the frame before explains it. A young
    scene (its ring not full) leaves both to the frame before."""
    flicker = [-0.04, 0.03, -0.02, 0.04, -0.03]
    assert min(_patch_fresh(_full_wall_scene(1), 2, flicker)) > 0.8
    assert max(_patch_fresh(_full_wall_scene(1, flicker_m=1.0), 2, flicker)[1:]) < 0.05  # no such flicker
    rests = _patch_fresh(_full_wall_scene(1), 2, [-0.04] * 4)
    assert rests[0] > 0.8 and max(rests[1:]) < 0.05
    young = _ref()
    _learn([young], [_wall(np.random.default_rng(3)) for _ in range(6)])
    shares = _patch_fresh(young, 2, flicker)
    assert shares[0] > 0.8 and max(shares[1:]) < 0.05


def test_a_live_scene_whose_returns_part_lets_the_frame_before_explain_a_flickering_offset():
    """Interference repeating at one place in every other frame, 3 cm off (too close to part the pixel as
    split), leaves the scene's median between the two depths: a clean frame after an interfered one changes
    as much as the interference does. Where clean returns are apart by more than ``flicker_m`` the flicker
    is no evidence: each frame is as fresh as with no flicker rule at all (``flicker_m`` beyond any)."""
    offsets = [0.0, 0.03, 0.0, 0.03, 0.0, 0.03]
    ref = _full_wall_scene(4, part=int(0.03 * SCALE))
    assert not ref._single[40:60, 30:70].any() and ref._steady[40:60, 30:70].mean() > 0.9
    shares = _patch_fresh(ref, 5, offsets)
    assert shares == _patch_fresh(_full_wall_scene(4, part=int(0.03 * SCALE), flicker_m=1.0), 5, offsets)


def test_a_deferred_repair_reads_the_live_scene_as_it_was():
    """``repair_later`` on a flickering patch (fresh through ``flicker_m``, where the scene's clean returns
    agree), called after the scene took in frames that part those pixels: bit for bit what ``repair`` gave
    at once."""
    rng = np.random.default_rng(13)
    now_ref, later_ref = _full_wall_scene(1), _full_wall_scene(1)
    before, hit = _patched(_wall(rng), -0.03), _patched(_wall(rng), 0.03)
    for ref in (now_ref, later_ref):
        ref.evidence(before)
    now = now_ref.repair(now_ref.evidence(hit))
    later = later_ref.repair_later(later_ref.evidence(hit))
    parted = [_wall(rng) for _ in range(2 * SHIPPED.frames)]
    for f in parted[1::2]:
        f[40:60, 30:70] += int(0.03 * SCALE)
    _learn([later_ref], parted)
    assert not later_ref._single[40:60, 30:70].any()
    got = later()
    assert now.fill[40:60, 30:70].mean() > 0.8
    for a, b in zip(now, got, strict=True):
        assert np.array_equal(a, b)
