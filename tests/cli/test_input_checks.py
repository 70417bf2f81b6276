"""Input checks that catch real mistakes before any work: a depth scale that fits another sensor better
(over frames sampled through the whole input), scenes beyond the default range, frames with no valid
depth, intensity images in a depth folder, frame sizes far from the models' training; and a console
that says which scale it used and writes "n/a" where a figure does not apply."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from d2sr.errors import InputError
from d2sr.frames import Frame
from d2sr.frames.base import looks_like_intensity, probe
from d2sr.frames.png import encode_png
from helpers import d2sr_inprocess


def _run(args: list[str]) -> tuple[int, str, str]:
    return d2sr_inprocess(*args)


def _room(rng: np.random.Generator, metres: float, shape: tuple[int, int] = (96, 128)) -> np.ndarray:
    """A smooth depth frame (a tilted plane) around ``metres``, with some holes."""
    h, w = shape
    d = metres * (1 + 0.3 * np.linspace(-1, 1, w)[None, :] + 0.1 * np.linspace(-1, 1, h)[:, None])
    d = d * (1 + 0.001 * rng.standard_normal(shape))
    d[rng.random(shape) < 0.1] = 0
    return d


def _folder(root: Path, frames: list[np.ndarray], scale: float) -> Path:
    root.mkdir(parents=True)
    for i, m in enumerate(frames):
        (root / f"f{i:03d}.png").write_bytes(encode_png(np.rint(m * scale).astype(np.uint16), "x"))
    return root


def test_millimetres_read_as_raw_l515_are_named():
    rng = np.random.default_rng(0)
    mm = [Frame(f"{i}", np.rint(_room(rng, 2.5) * 1000).astype(np.uint16)) for i in range(6)]
    warnings = probe(mm, 4000.0)
    assert any("at 1000 (millimetres) it would be 2.50 m" in w for w in warnings), warnings
    assert probe(mm, 1000.0) == []  # the right scale: nothing to say


def test_scale_is_checked_through_the_whole_input_not_the_first_frame(tmp_path, weights):
    rng = np.random.default_rng(1)
    # the first frame is fine at the default scale; the other 11 are 0.1 mm counts (30x too far)
    frames = [_room(rng, 2.0)] + [_room(rng, 2.0) * 10 for _ in range(11)]
    src = _folder(tmp_path / "in", frames, 1000)
    code, _, err = _run(["detect", str(src), "--out", str(tmp_path / "s.csv"), "--models", str(weights)])
    assert code == 2 and "sampled frames" in err and "scale" in err, err
    assert not (tmp_path / "s.csv").exists()


def test_max_range_admits_a_large_hall(tmp_path, weights):
    rng = np.random.default_rng(2)
    src = _folder(tmp_path / "hall", [_room(rng, 18.0) for _ in range(3)], 1000)
    args = ["detect", str(src), "--out", str(tmp_path / "s.csv"), "--models", str(weights)]
    code, _, err = _run(args)
    assert code == 2 and "--max-range" in err
    code, out, err = _run([*args, "--max-range", "30"])
    assert code == 0, err
    assert "depth scale 1000 units per metre (default: millimetres)" in out


def test_the_scale_used_and_its_source_are_printed(tmp_path, weights):
    rng = np.random.default_rng(3)
    src = _folder(tmp_path / "in", [_room(rng, 2.0) for _ in range(2)], 4000)
    (src / "meta.json").write_text('{"depth_scale": 4000}')
    code, out, err = _run(["detect", str(src), "--out", str(tmp_path / "a.csv"), "--models", str(weights)])
    assert code == 0 and "depth scale 4000 units per metre (from the recording)" in out, out + err
    args = ["detect", str(src), "--out", str(tmp_path / "b.csv"), "--models", str(weights)]
    code, out, err = _run([*args, "--depth-scale", "1000", "--recording-scale-wrong"])
    assert "(as given)" in out and "it says its depth scale is 4000; using the one given, 1000" in err


@pytest.mark.parametrize("given", ["40000", "1000", "4001"])
def test_a_depth_scale_that_contradicts_the_recording_s_is_refused_before_any_work(tmp_path, weights, given):
    """recover l515/dev1 --depth-scale 40000 (its intrinsics say 4000) repaired 41 of 195 clean frames by up
    to 11 m and exited 0; a scale too large passed the range check. Now one line naming both scales, exit 2,
    nothing written, in the CLI and the library alike; the user says when the recording's own is wrong."""
    import d2sr
    from d2sr.runtime.settings import RunSettings

    rng = np.random.default_rng(3)
    src = _folder(tmp_path / "in", [_room(rng, 2.0) for _ in range(3)], 4000)
    (src / "meta.json").write_text('{"depth_scale": 4000}')
    out = tmp_path / "o"
    code, _, err = _run(
        ["recover", str(src), "--out", str(out), "--models", str(weights), "--depth-scale", given]
    )
    assert code == 2 and not out.exists(), err
    line = err.strip().splitlines()[-1]
    assert f"--depth-scale {given} given, but the recording says 4000" in line, err
    assert "--recording-scale-wrong" in line and len(err.strip().splitlines()) == 1, err
    with pytest.raises(InputError, match="recording_scale_wrong"):
        d2sr.recover_recording(src, out, RunSettings(depth_scale=float(given), models=weights))
    assert not out.exists()
    learn = ["scene", "learn", str(src), "--out", str(tmp_path / "s.npz"), "--depth-scale", given]
    assert _run(learn)[0] == 2 and not (tmp_path / "s.npz").exists()
    # Said explicitly: taken, with a warning; the recording's own scale or none given: as before.
    code, _, err = _run(
        ["recover", str(src), "--out", str(out), "--models", str(weights), "--depth-scale", "1000",
         "--recording-scale-wrong"]
    )  # fmt: skip
    assert code == 0 and "using the one given, 1000" in err, err
    for same in (["--depth-scale", "4000"], []):
        args = ["recover", str(src), "--out", str(tmp_path / f"same{len(same)}"), "--models", str(weights)]
        assert _run([*args, *same])[0] == 0


def test_frames_with_no_valid_depth_are_named(tmp_path, weights):
    rng = np.random.default_rng(4)
    src = _folder(tmp_path / "in", [_room(rng, 2.0), np.zeros((96, 128)), np.zeros((96, 128))], 1000)
    code, _, err = _run(["recover", str(src), "--out", str(tmp_path / "o"), "--models", str(weights)])
    assert code == 0
    assert "2 of 3 frames have no valid depth" in err


def test_an_intensity_image_in_a_depth_folder_is_named(tmp_path, weights):
    rng = np.random.default_rng(5)
    ir = [rng.gamma(2.0, 0.4, (96, 128)) + 0.05 for _ in range(2)]  # textured, few zeros
    assert looks_like_intensity(np.rint(ir[0] * 1000).astype(np.uint16))
    assert not looks_like_intensity(np.rint(_room(rng, 2.0) * 1000).astype(np.uint16))
    src = _folder(tmp_path / "in", ir, 1000)
    _, _, err = _run(["detect", str(src), "--out", str(tmp_path / "s.csv"), "--models", str(weights)])
    assert "intensity (IR) image" in err


def test_far_off_sizes_warn_and_huge_frames_are_refused():
    rng = np.random.default_rng(6)
    small = Frame("s", np.rint(_room(rng, 2.0, (40, 60)) * 1000).astype(np.uint16))
    assert any("60x40" in w for w in probe([small], 1000.0))
    huge = Frame("h", np.ones((4100, 4100), np.uint16) * 2000)
    with pytest.raises(InputError, match="4100x4100"):
        probe([huge], 1000.0)


def test_run_on_a_recording_says_n_a_where_nothing_applies(tmp_path, weights):
    rng = np.random.default_rng(7)
    src = _folder(tmp_path / "in", [_room(rng, 2.0) for _ in range(3)], 1000)
    code, out, err = _run(["run", str(src), "--out", str(tmp_path / "r"), "--models", str(weights)])
    assert code == 0, err
    assert "n/a" in out  # no ground truth: precision, recall and RMSE do not apply
    rows = list(csv.DictReader((tmp_path / "r" / "log.csv").open()))
    assert rows and all(r["time_s"] == "n/a" and r["interfered"] == "n/a" for r in rows)


def test_run_fill_is_refused_where_no_slot_is_skipped(tmp_path, weights):
    # A recording's frames are all real (d2sr fill synthesizes a duty-cycled one): one line, exit 2.
    rng = np.random.default_rng(8)
    src = _folder(tmp_path / "in", [_room(rng, 2.0) for _ in range(3)], 1000)
    code, _, err = _run(["run", str(src), "--out", str(tmp_path / "r"), "--fill", "--models", str(weights)])
    assert (
        code == 2
        and "fill on a recording" in err
        and "d2sr fill" in err
        and len(err.strip().splitlines()) == 1
    )
    assert not (tmp_path / "r").exists()


def test_a_refused_output_is_named_by_its_flag(tmp_path):
    theirs = tmp_path / "theirs.csv"
    theirs.write_text("a user's file\n")
    rec = tmp_path / "rec"
    rec.mkdir()
    (rec / "0.png").write_bytes(encode_png(np.full((48, 64), 1500, np.uint16), "0.png"))
    code, _, err = d2sr_inprocess("detect", str(rec), "--out", str(theirs), "--overwrite")
    assert code == 2 and err.startswith(f"d2sr: error: --out {theirs} exists and d2sr did not write it"), err
    assert theirs.read_text() == "a user's file\n"
