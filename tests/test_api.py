"""The library's face: d2sr.repair and d2sr.Pipeline against d2sr recover, units in and out, bad input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

import d2sr
from d2sr.frames.png import encode_png
from d2sr.sim.interference import corrupt
from d2sr.synth.recording import FillSettings
from helpers import d2sr_inprocess, room

SCALE = 4000.0


def _interfered(seed: int = 0) -> np.ndarray:
    clean = room(seed)
    where = np.zeros(clean.shape, bool)
    where[150:260, :] = True
    frame, _ = corrupt(clean, SCALE, where, np.random.default_rng(seed))
    return frame


def test_repair_matches_recover_on_a_one_frame_folder(tmp_path):
    frame = _interfered()
    src = tmp_path / "in"
    src.mkdir()
    (src / "f.png").write_bytes(encode_png(frame, "f"))
    for every in (False, True):
        out = tmp_path / f"out{every}"
        code, _, err = d2sr_inprocess(
            "recover",
            str(src),
            "--depth-scale",
            "4000",
            "--out",
            str(out),
            *(["--repair", "all"] if every else []),
        )
        assert code == 0, err
        r = d2sr.repair(frame, depth_scale=SCALE, repair="all" if every else "flagged")
        assert r.depth.dtype == np.uint16 and r.mask.dtype == bool
        assert np.array_equal(r.depth, cv2.imread(str(out / "f.png"), cv2.IMREAD_UNCHANGED))
        assert np.array_equal(r.mask, cv2.imread(str(out / "masks" / "f.png"), cv2.IMREAD_UNCHANGED) > 0)
        assert np.array_equal(r.depth[~r.mask], frame[~r.mask])  # only repaired pixels differ
        assert 0 <= r.score <= 1 and r.interfered == (r.score >= 0.5)
    assert r.mask.any()  # --repair all on an interfered frame repairs something


def test_repair_takes_metres_and_gives_metres():
    frame = _interfered(1)
    units = d2sr.repair(frame, depth_scale=SCALE, repair="all")
    metres = frame.astype(np.float32) / np.float32(SCALE)
    metres[0, :5] = np.nan  # no return, as ROS writes it: kept as it was
    m = d2sr.repair(metres, repair="all")
    assert m.depth.dtype == np.float32 and np.isnan(m.depth[0, :5]).all()
    assert np.array_equal(m.depth[~m.mask], metres[~m.mask], equal_nan=True)
    assert m.interfered == units.interfered and abs(m.score - units.score) < 1e-3
    agree = (m.mask == units.mask).mean()
    assert agree > 0.999  # the same frame in other units: the same repair up to rounding
    both = m.mask & units.mask
    assert np.abs(m.depth[both] - units.depth[both] / SCALE).max() < 2e-3
    f64 = d2sr.repair(metres.astype(np.float64), repair="all")
    assert f64.depth.dtype == np.float64


def test_pipeline_runs_a_sequence_and_reports_its_window():
    p = d2sr.Pipeline(depth_scale=SCALE, active_frames=6)
    windows = []
    for i in range(13):
        frame = _interfered(i) if i % 2 else room(i)
        r = p.process(frame, timestamp_ns=i * 33_000_000)
        assert r.depth.dtype == np.uint16 and r.window is not None
        assert np.array_equal(r.depth[~r.mask], frame[~r.mask])
        if not r.interfered:
            assert not r.mask.any()  # a frame the detector passes comes out as it went in
        windows.append(r.window)
    assert [w.period for w in windows] == [0] * 6 + [1] * 6 + [2]  # 6 frames make a period (open loop)
    assert all(w.active_frames == 6 and w.total_frames == 30 for w in windows)
    assert p.window.active(p.window.offset) and not p.window.active((p.window.offset + 6) % 30)


def test_pipeline_repairs_as_recover_does_over_a_sequence(tmp_path):
    frames = [_interfered(i) if i % 3 else room(i) for i in range(6)]
    src = tmp_path / "in"
    src.mkdir()
    for i, f in enumerate(frames):
        (src / f"f{i}.png").write_bytes(encode_png(f, "f"))
    code, _, err = d2sr_inprocess("recover", str(src), "--depth-scale", "4000", "--out", str(tmp_path / "o"))
    assert code == 0, err
    p = d2sr.Pipeline(depth_scale=SCALE)
    for i, f in enumerate(frames):
        written = cv2.imread(str(tmp_path / "o" / f"f{i}.png"), cv2.IMREAD_UNCHANGED)
        assert np.array_equal(p.process(f).depth, written)


_NOWHERE = Path("/nonexistent/d2sr")
_FILL = FillSettings(active_frames=6)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: d2sr.repair(np.zeros((4, 4, 3), np.uint16)), "2-D"),
        (lambda: d2sr.repair(np.zeros((48, 64), np.int32)), "uint16"),
        (lambda: d2sr.repair(np.ones((48, 64), np.float32), depth_scale=1000), "metres"),
        (lambda: d2sr.repair(-np.ones((48, 64), np.float32)), "negative"),
        (lambda: d2sr.repair([[1, 2]]), "numpy array"),
        (lambda: d2sr.repair(room(), depth_scale=0), "positive"),
        (lambda: d2sr.repair(room(), depth_scale=1), "scale"),  # a median of 2500 m
        (lambda: d2sr.repair(room(), model="unet9"), "unknown"),
        (lambda: d2sr.repair(room(), repair="some"), "repair"),
        (lambda: d2sr.repair(room(), threshold=2.0), "threshold"),
        (lambda: d2sr.repair(room(), models=Path("/nonexistent")), "no such"),
        (lambda: d2sr.Pipeline(controller="oracle"), "controller"),
        (lambda: d2sr.Pipeline(active_frames=0), "active_frames"),
        (lambda: d2sr.Pipeline(active_frames=6.0), "active_frames"),
        (lambda: d2sr.Pipeline(desync={"active_frames": 6}), "desync must be DesyncSettings"),
        (lambda: d2sr.Pipeline(depth_scale=-5), "depth_scale must be a positive"),  # was taken until a frame
        (lambda: d2sr.Pipeline(depth_scale=0), "depth_scale must be a positive"),
        (lambda: d2sr.open_frames(None), "a recording is a path"),  # a TypeError from pathlib before
        # The recording-level calls check their arguments before any work (AttributeErrors and TypeErrors
        # from deep inside before).
        (lambda: d2sr.recover_recording(None, _NOWHERE), "input must be a path"),
        (lambda: d2sr.recover_recording(_NOWHERE, 5), "out must be a path"),
        (
            lambda: d2sr.recover_recording(_NOWHERE, _NOWHERE / "o", {"threshold": 0.5}),
            "settings must be Run",
        ),
        (lambda: d2sr.recover_recording(_NOWHERE, _NOWHERE / "o", progress=5), "progress must be a function"),
        (lambda: d2sr.detect_recording(_NOWHERE, _NOWHERE / "o.csv", "fast"), "settings must be RunSettings"),
        (lambda: d2sr.learn_scene_recording(_NOWHERE, None), "out must be a path"),
        (lambda: d2sr.fill_recording(_NOWHERE, _NOWHERE / "o", _FILL, say="quiet"), "say must be a function"),
        (lambda: d2sr.recover_fleet("rec", _NOWHERE / "o"), "recordings must be a list of paths"),
        (lambda: d2sr.recover_fleet([_NOWHERE, None], _NOWHERE / "o"), "recording 1 must be a path"),
    ],
)
def test_bad_input_is_one_d2sr_error(call, message):
    with pytest.raises(d2sr.D2SRError, match=message):
        call()


@pytest.mark.slow  # a subprocess: not in make test-fast
def test_import_d2sr_is_light_and_lists_its_names():
    import subprocess
    import sys

    code = "import sys, d2sr; print(sorted(m for m in ('onnxruntime', 'torch', 'cv2') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    assert {"repair", "Pipeline", "recover_recording", "open_frames"} <= set(dir(d2sr))
    with pytest.raises(AttributeError):
        _ = d2sr.not_a_name


def test_a_pipeline_runs_the_desync_settings_it_is_given_and_their_fields_over_them() -> None:
    d = d2sr.DesyncSettings(controller="static", active_frames=9, seed=3)
    p = d2sr.Pipeline(depth_scale=SCALE, desync=d)
    assert p.desync == d and p.window.active_frames == 9 and p.loop.controller.active_frames == 9
    over = d2sr.Pipeline(depth_scale=SCALE, desync=d, active_frames=4)
    assert over.desync == d2sr.DesyncSettings(controller="static", active_frames=4, seed=3)
    assert over.window.active_frames == 4
