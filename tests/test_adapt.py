"""``d2sr adapt``: refusals, and a short end-to-end run whose model folder the other commands take."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.contract import WEIGHTS
from helpers import d2sr_inprocess


def _room(folder: Path, n: int, shape: tuple[int, int] = (96, 128), seed: int = 0) -> Path:
    """A static scene (a slanted floor and a box) in mm, with a little noise per frame."""
    folder.mkdir(parents=True)
    h, w = shape
    y = np.linspace(1.0, 3.0, h, dtype=np.float32)[:, None] * np.ones((1, w), np.float32)
    y[20:50, 40:80] = 1.2
    rng = np.random.default_rng(seed)
    for i in range(n):
        d = y + rng.normal(0, 0.004, y.shape).astype(np.float32)
        cv2.imwrite(str(folder / f"{i:05d}.png"), np.rint(d * 1000).astype(np.uint16))
    return folder


def _hashes(folder: Path) -> dict[str, str]:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()
    }


def test_adapt_refuses_short_empty_and_mixed_input(tmp_path):
    short = _room(tmp_path / "short", 20)
    code, _out, err = d2sr_inprocess(
        "adapt", "--clean", str(short), "--depth-scale", "1000", "--out", str(tmp_path / "m")
    )
    assert code == 2 and "at least 50" in err and not (tmp_path / "m").exists()
    a, b = _room(tmp_path / "a", 30), _room(tmp_path / "b", 30, (64, 96))
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(a), "--clean", str(b), "--depth-scale", "1000", "--out", str(tmp_path / "m")
    )
    assert code == 2 and "mix sizes" in err and not (tmp_path / "m").exists()
    zeros = tmp_path / "zeros"
    zeros.mkdir()
    for i in range(60):
        cv2.imwrite(str(zeros / f"{i:05d}.png"), np.zeros((96, 128), np.uint16))
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(zeros), "--depth-scale", "1000", "--out", str(tmp_path / "m")
    )
    assert code == 2 and "no valid depth" in err and not (tmp_path / "m").exists()
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(a), "--depth-scale", "1000", "--out", str(WEIGHTS), "--overwrite"
    )
    assert code == 2 and err.count("\n") == 1  # never into (or over) the models it starts from


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_adapt_writes_a_model_folder_that_detect_and_recover_take(tmp_path):
    clean = _room(tmp_path / "clean", 60)
    models = tmp_path / "models"
    shipped = _hashes(WEIGHTS)
    code, out, err = d2sr_inprocess(
        "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(models), "--minutes", "0.1"
    )
    assert code == 0, err
    for f in ("detector.onnx", "unet8.onnx", "detector.safetensors", "unet8.safetensors", "adapt.json"):
        assert (models / f).is_file(), f
    # the detector is the adapted model's mask, at the repair threshold the folder's unet8 carries
    from safetensors.numpy import load_file

    from d2sr.models.store import mask_logit

    det, rec = load_file(models / "detector.safetensors"), load_file(models / "unet8.safetensors")
    assert all(np.array_equal(det[f"net.{k}"], v) for k, v in rec.items())
    assert float(det["cut"]) == pytest.approx(mask_logit(models / "unet8.safetensors"))
    # its mask threshold keeps the 1% rule for the repair recover writes (two passes), or is the highest
    from d2sr.train.loop import MASK_LOGITS

    held = json.loads((models / "adapt.json").read_text())["held_out"]["recovery"]["adapted"]
    assert held["clean_changed"] <= 0.01 or held["mask_logit"] == MASK_LOGITS[0]
    assert "passes" in held["rule"]
    assert "false alarms" in out and "--models" in out
    card = (models / "detector.md").read_text()  # a model card: what it is, data, command, metrics, date
    assert "mask-detector" in card and all(f"## {t}" in card for t in ("Data", "Command", "Metrics", "Date"))
    code, out, err = d2sr_inprocess(
        "detect",
        str(clean),
        "--depth-scale",
        "1000",
        "--models",
        str(models),
        "--out",
        str(tmp_path / "f.csv"),
    )
    assert code == 0, err
    code, out, err = d2sr_inprocess(
        "recover",
        str(clean),
        "--depth-scale",
        "1000",
        "--models",
        str(models),
        "--all",
        "--out",
        str(tmp_path / "r"),
    )
    assert code == 0, err
    # the shipped weights were not touched (every file's bytes), and a second run on the same folder
    # resumes, not refuses
    assert _hashes(WEIGHTS) == shipped
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(models), "--minutes", "0.1"
    )
    assert code == 0, err
    # another budget cannot resume it: the result would be neither run
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(models), "--minutes", "0.2"
    )
    assert code == 2 and "another --minutes" in err and err.count("\n") == 1


@pytest.mark.slow
def test_adapt_gives_the_same_model_twice(tmp_path, monkeypatch):
    """The budget buys a number of steps, not seconds: the same command gives the same weights."""
    from safetensors.numpy import load_file

    monkeypatch.setattr("d2sr.train.adapt.TIME_CAP", 1e6)  # a busy test machine must not cut a run short
    clean = _room(tmp_path / "clean", 60)
    runs = []
    for k in (1, 2):
        out = tmp_path / f"m{k}"
        code, _, err = d2sr_inprocess(
            "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(out), "--minutes", "0.05"
        )
        assert code == 0, err
        card = json.loads((out / "adapt.json").read_text())
        assert not any(f["stopped_at_time_cap"] for f in card["training"].values())
        runs.append([load_file(out / f"{m}.safetensors") for m in ("detector", "unet8")])
    shipped = load_file(WEIGHTS / "unet8.safetensors")
    for a, b in zip(*runs, strict=True):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    assert any(not np.array_equal(runs[0][1][k], shipped[k]) for k in shipped)  # it did train


def test_threshold_takes_the_widest_margin_and_else_the_false_alarm_target():
    from d2sr.contract import THRESHOLD
    from d2sr.train.adapt import choose_threshold

    clean = np.linspace(0.0, 0.3, 100)
    bad = np.linspace(0.9, 1.0, 50)
    seen = np.ones(50, bool)
    t = choose_threshold(clean, bad, seen, 0.01)
    assert 0.4 < t < 0.85  # well clear of both: later frames drift
    # Overlap: the false-alarm target wins (just above the clean frames' 99th percentile).
    assert abs(choose_threshold(np.linspace(0, 0.8, 101), bad * 0.6, seen, 0.01) - 0.812) < 0.005
    # Frames too lightly hit to see do not drag the threshold down.
    faint = np.r_[bad, np.full(50, 0.01)]
    assert choose_threshold(clean, faint, np.r_[seen, np.zeros(50, bool)], 0.01) == t
    assert choose_threshold(np.array([]), bad, seen, 0.01) == THRESHOLD
    # A floor holds against held-out frames that separate low (the mask detector's: 0.5).
    low = choose_threshold(clean * 0.1, bad * 0.3, seen, 0.01)
    assert low < 0.5 and choose_threshold(clean * 0.1, bad * 0.3, seen, 0.01, floor=0.5) == 0.5
