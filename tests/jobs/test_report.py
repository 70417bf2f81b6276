"""report.html (d2sr.jobs.report): what a recording job did, for a person to open."""

from __future__ import annotations

import base64
import json
import re

import cv2
import numpy as np

from d2sr.frames import Frame
from d2sr.jobs.report import WORST, Report
from d2sr.runtime.loop import Capture, Result
from helpers import d2sr_inprocess


def _result(name: str, flagged: bool, changed: int, reason: str = "", fill: int = 0) -> Result:
    raw = np.full((24, 32), 8000, np.uint16)
    raw[0, :fill] = 0  # no return there
    out, mask = raw.copy(), np.zeros(raw.shape, bool)
    mask.ravel()[:changed] = True
    out[mask] = 6000
    return Result(Capture(Frame(name, raw), 4000.0), 0.9 if flagged else 0.1, flagged, out, mask, 0, 0,
                  reason=reason)  # fmt: skip


def test_the_report_lists_the_frames_flagged_or_cleared_and_counts_every_invented_return():
    rep = Report("test")
    rep.add(_result("clean", False, 0))
    rep.add(_result("cleared", False, 0, "cleared by scene"))
    for k in range(WORST + 2):
        rep.add(_result(f"hit{k}", True, 10 * (k + 1), "detector", fill=3))
    page = rep.html()
    rows = re.findall(r"<tr><td>([^<]*)</td>", page)
    assert rows == ["cleared", *(f"hit{k}" for k in range(WORST + 2))]  # the clean frame is not listed
    assert rep.filled_px == 3 * (WORST + 2) and f"and {rep.filled_px} pixels with no return" in page
    images = re.findall(r"<img alt='before \(m\)' src='data:image/png;base64,([A-Za-z0-9+/=]+)'", page)
    assert len(images) == WORST  # the most changed only, most first
    assert re.findall(r"<h3>([^:]*):", page) == [f"hit{k}" for k in range(WORST + 1, 1, -1)]
    nan = _result("scene", True, 5, "scene")
    rep.add(Result(nan.capture, float("nan"), True, nan.depth, nan.mask, 0, 0, reason="scene"))
    assert "<tr><td>scene</td><td>-</td>" in rep.html()  # the detector was not run: no "nan" shown
    for b64 in images:
        png = cv2.imdecode(np.frombuffer(base64.b64decode(b64), np.uint8), cv2.IMREAD_COLOR)
        assert png is not None and png.shape == (24, 32, 3)  # the frame's own size


def _bars(page: str) -> dict[str, tuple[float, float]]:
    """Each panel's title -> its colour bar's (low, high) in metres."""
    found = re.findall(r"<div class='bar'>([-0-9.]+)<img[^>]*>([-0-9.]+)</div><figcaption>([^<]*)<", page)
    return {title: (float(lo), float(hi)) for lo, hi, title in found}


def test_returns_moved_and_depths_given_to_empty_pixels_are_shown_apart_each_on_its_own_scale():
    """Real Kinect v2 repairs: 2-5 cm corrections beside an empty pixel given 0.7 m. On one after-minus-before
    scale the corrections were flat grey; now each kind has its panel and colour bar."""
    raw = np.full((48, 64), 4000, np.uint16)  # 1 m
    raw[:4, :4] = 0
    out, mask = raw.copy(), np.zeros(raw.shape, bool)
    mask[10:20, 10:20] = mask[:4, :4] = True
    out[10:20, 10:20] = 4000 - 80  # moved 2 cm near
    out[:4, :4] = 2800  # 0.7 m given to pixels that had no return
    rep = Report("t")
    rep.add(Result(Capture(Frame("f", raw), 4000.0), 0.9, True, out, mask, 0, 0, reason="detector"))
    page = rep.html()
    bars = _bars(page)
    moved = next(v for k, v in bars.items() if k.startswith("returns moved"))
    given = next(v for k, v in bars.items() if k.startswith("no return given a depth"))
    assert moved == (-0.02, 0.02) and given == (0.7, 0.7 + 0.001)
    assert (
        "100 returns moved" in page and "100 returns moved and 16 pixels with no return given a depth" in page
    )
    assert "<td>100</td><td>16</td><td>0.020</td>" in page  # returns moved, filled, largest move of a return


def test_a_recording_where_nothing_changed_says_so_and_shows_one_frame():
    rep = Report("t")
    for k in range(3):
        rep.add(_result(f"c{k}", False, 0))
    page = rep.html()
    assert "Nothing changed" in page and "<table>" not in page
    assert re.findall(r"<h3>([^<]*)</h3>", page) == ["c0"] and "depth (m)" in page


def test_recover_writes_its_report_in_the_output_and_no_report_leaves_it_out(tmp_path, weights):
    src = tmp_path / "rec"
    src.mkdir()
    rng = np.random.default_rng(0)
    for i in range(4):
        cv2.imwrite(str(src / f"{i:03d}.png"), (rng.uniform(1.5, 3.0, (96, 128)) * 1000).astype(np.uint16))
    args = ["recover", str(src), "--models", str(weights), "--repair", "all", "--no-scene"]
    code, out, err = d2sr_inprocess(*args, "--out", str(tmp_path / "a"))
    assert code == 0, err
    page = (tmp_path / "a" / "report.html").read_text()
    assert "4 frames" in page and "report.html" in out
    assert "report.html" in json.loads((tmp_path / "a" / ".d2sr-manifest.json").read_text())["files"]
    code, _, err = d2sr_inprocess(*args, "--no-report", "--out", str(tmp_path / "b"))
    assert code == 0, err
    assert not (tmp_path / "b" / "report.html").exists()


def test_a_recording_s_run_writes_its_report_in_the_run_folder(tmp_path):
    from d2sr.frames import open_frames
    from d2sr.jobs.session import Recording, run_recording
    from d2sr.runtime.settings import LoopSettings, RunSettings
    from helpers import FakeNet

    src = tmp_path / "rec"
    src.mkdir()
    for i in range(4):
        f = np.full((48, 64), 8000, np.uint16)
        f[0, 0] = 1 if i == 2 else 8000  # FakeNet flags frame 2
        cv2.imwrite(str(src / f"{i:03d}.png"), f)
    recording = Recording(open_frames(src), 4000.0, "rec")
    plan = LoopSettings(controller="static")
    run_recording(FakeNet(), recording, tmp_path / "run", RunSettings(scene=False), plan)
    page = (tmp_path / "run" / "report.html").read_text()
    assert re.findall(r"<tr><td>([^<]*)</td>", page) == ["002"] and "4 frames; 1 flagged" in page
    quiet = LoopSettings(controller="static", report=False)
    run_recording(
        FakeNet(), Recording(open_frames(src), 4000.0, "rec"), tmp_path / "r2", RunSettings(), quiet
    )
    assert not (tmp_path / "r2" / "report.html").exists()
