"""Smaller holes of the second hostile-input probe (issue 79, part 6)."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from d2sr.atomic.naming import cell
from d2sr.errors import InputError
from d2sr.fleet.names import output_names
from d2sr.frames import Frame
from d2sr.frames.png import decode_png
from d2sr.jobs.report import Report
from d2sr.runtime.loop import Capture, Result
from d2sr.scene.stats import CleanStats
from d2sr.scene.stored import StoredScene
from helpers import d2sr_inprocess


@pytest.mark.parametrize("name", ['=HYPERLINK("x")', "+1", "-2+3", "@SUM(A1)"])
def test_a_frame_name_that_reads_as_a_formula_is_text_in_the_detect_csv(tmp_path, weights, name):
    assert cell(name) == "'" + name and cell("\tx") == "'\tx" and cell("frame_001") == "frame_001"
    import cv2

    src = tmp_path / "in"
    src.mkdir()
    cv2.imwrite(str(src / f"{name}.png"), np.full((96, 128), 8000, np.uint16))
    code, _, err = d2sr_inprocess(
        "detect", str(src), "--out", str(tmp_path / "d.csv"), "--models", str(weights)
    )
    assert code == 0, err
    import csv

    rows = list(csv.reader((tmp_path / "d.csv").read_text().splitlines()))
    assert rows[1][0] == "'" + name


def test_a_name_that_is_not_utf8_is_escaped_in_the_report():
    name = b"caf\xe9".decode("utf-8", "surrogateescape")
    raw = np.full((24, 32), 8000, np.uint16)
    mask = np.zeros(raw.shape, bool)
    mask[:2] = True
    rep = Report(name)
    rep.add(Result(Capture(Frame(name, raw), 4000.0), 0.9, True, raw - 10, mask, 0, 0, reason="detector"))
    page = rep.html()
    page.encode("utf-8")  # no lone surrogates: the page is what it says it is
    assert "caf\\xe9" in page


def _stored(tmp_path, **change: float) -> StoredScene:
    shape = (8, 8)
    arrays = {k: np.full(shape, 2.0, np.float32) for k in ("median", "nz_median", "lo", "hi")}
    arrays["rate"] = np.ones(shape, np.float32)
    arrays["mean_err"] = np.zeros(shape, np.float32)
    for k, v in change.items():
        arrays[k][0, 0] = v
    scene = StoredScene(CleanStats(frames=16, **arrays), 4000.0, 16, "test")
    scene.save(tmp_path / "s.npz")
    return StoredScene.load(tmp_path / "s.npz")


@pytest.mark.parametrize(
    "change", [{"rate": -0.5}, {"rate": 3.0}, {"lo": 5.0}, {"hi": 1.0}, {"median": -1.0}]
)
def test_scene_statistics_no_clean_sequence_has_are_refused(tmp_path, change):
    _stored(tmp_path)  # the sensible one loads
    with pytest.raises(InputError, match="statistics"):
        _stored(tmp_path, **change)


def test_a_png_too_wide_says_so_rather_than_corrupt():
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    w = 16_777_216
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, 1, 16, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(b"\x00" + b"\x07\xd0" * w, 9)) + chunk(b"IEND", b"")
    with pytest.raises(InputError, match="pixels a side"):
        decode_png(png, "wide.png")


def test_a_recording_named_like_the_fleet_s_record_is_named_apart(tmp_path):
    for name in ("fleet.json", "other"):
        (tmp_path / name).mkdir()
    assert output_names([tmp_path / "fleet.json", tmp_path / "other"]) == ["fleet.json_", "other"]


@pytest.mark.parametrize(
    "text",
    ['{"depth_scale": ' + "9" * 5000 + "}", "[" * 30_000 + "]" * 30_000, '{"a": "' + "x" * (2 << 20) + '"}'],
)
def test_json_d2sr_reads_back_is_bounded_one_line(tmp_path, text):
    """A 5,000-digit number, nesting 30,000 deep, a file of megabytes: one line, never an unforeseen error."""
    from d2sr.atomic import made_by_d2sr
    from d2sr.atomic.manifest import made
    from d2sr.errors import OutputError
    from d2sr.frames import open_frames

    rec = tmp_path / "rec"
    rec.mkdir()
    import cv2

    cv2.imwrite(str(rec / "000.png"), np.full((96, 128), 8000, np.uint16))
    (rec / "meta.json").write_text(text)
    with pytest.raises(InputError, match=r"meta\.json"):
        open_frames(rec)
    out = tmp_path / "out.json"
    out.write_text(text)
    assert not made_by_d2sr(out)
    folder = tmp_path / "o"
    folder.mkdir()
    (folder / "a.png").write_bytes(b"x")
    (folder / ".d2sr-manifest.json").write_text(text)
    with pytest.raises(OutputError, match="did not make"):
        made(folder)
