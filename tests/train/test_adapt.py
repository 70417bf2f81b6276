"""``d2sr adapt``: refusals, and a short end-to-end run whose model folder the other commands take."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.contract.catalog import WEIGHTS
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
    # the detector is the adapted model's mask, at the repair threshold the folder's unet8 carries; or, if
    # the adapted models did worse on the held-out frames, the folder holds the ones it started from
    from safetensors.numpy import load_file

    from d2sr.models.store import mask_logit

    det, rec = load_file(models / "detector.safetensors"), load_file(models / "unet8.safetensors")
    kept = json.loads((models / "adapt.json").read_text())["kept"]
    if kept is None:
        assert all(np.array_equal(det[f"net.{k}"], v) for k, v in rec.items())
        assert float(det["cut"]) == pytest.approx(mask_logit(models / "unet8.safetensors"))
    else:
        assert all(
            (models / f).read_bytes() == (WEIGHTS / f).read_bytes() for f in ("unet8.onnx", "detector.onnx")
        )
    # its mask threshold keeps the 1% rule for the repair recover writes (two passes), or is the highest
    from d2sr.train.loop import MASK_LOGITS

    held = json.loads((models / "adapt.json").read_text())["held_out"]["recovery"]["adapted"]
    assert held["clean_changed"] <= 0.01 or held["mask_logit"] == MASK_LOGITS[0]
    assert "passes" in held["rule"]
    assert "false alarms" in out and ("--models" in out or kept is not None)
    card = (models / "detector.md").read_text()  # a model card: what it is, data, command, metrics, date
    assert all(f"## {t}" in card for t in ("Data", "Command", "Metrics", "Date"))
    assert ("mask-detector" in card) == (kept is None)
    assert (kept is None) == ("did not help" not in err)  # a kept start is said, not only written
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
        "--repair",
        "all",
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
    # another budget cannot resume it: the result would be neither run (refused before any work)
    code, _, err = d2sr_inprocess(
        "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(models), "--minutes", "2"
    )
    assert code == 2 and "another budget (minutes)" in err and err.count("\n") == 1


@pytest.mark.slow
def test_adapt_gives_the_same_model_twice(tmp_path, monkeypatch):
    """The budget buys a number of steps, not seconds: the same command gives the same weights."""
    from safetensors.numpy import load_file

    clean = _room(tmp_path / "clean", 60)
    runs = []
    for k in (1, 2):
        out = tmp_path / f"m{k}"
        code, _, err = d2sr_inprocess(
            "adapt", "--clean", str(clean), "--depth-scale", "1000", "--out", str(out), "--minutes", "0.05"
        )
        assert code == 0, err
        card = json.loads((out / "adapt.json").read_text())
        assert card["training"]["recovery"]["steps"] == card["plan"]["steps"]  # the plan, whatever the load
        runs.append(
            {f.name: f.read_bytes() for f in sorted(out.iterdir()) if f.suffix in (".safetensors", ".onnx")}
        )
    assert runs[0] == runs[1] and len(runs[0]) >= 4  # bit for bit, weights and ONNX
    shipped = load_file(WEIGHTS / "unet8.safetensors")
    trained = load_file(tmp_path / "m1" / "unet8.safetensors")
    if card["kept"] is None:
        assert any(not np.array_equal(trained[k], shipped[k]) for k in shipped)  # it did train
    else:  # it did worse on its held-out frames: the folder holds what it started from
        assert all(np.array_equal(trained[k], shipped[k]) for k in shipped)


def test_a_worse_adapted_model_is_not_handed_out():
    from d2sr.train.adapt import worse

    def held(f1: tuple[float, float], recall: tuple[float, float], alarms: tuple[float, float]) -> dict:
        return {
            "detector": {
                k: {"recall": r, "false_alarms": a}
                for k, r, a in zip(("shipped", "adapted"), recall, alarms, strict=True)
            },
            "recovery": {k: {"mask_f1": f} for k, f in zip(("shipped", "adapted"), f1, strict=True)},
        }

    assert worse(held((0.45, 0.35), (0.7, 0.8), (0.01, 0.01))) == "mask F1 0.45 -> 0.35"
    assert "recall 71.8% -> 60.3%" in worse(held((0.4, 0.5), (0.718, 0.603), (0.01, 0.01)))
    assert worse(held((0.4, 0.5), (0.718, 0.603), (0.05, 0.0))) is None  # fewer false alarms for it
    assert worse(held((0.4, 0.402), (0.7, 0.698), (0.01, 0.01))) is None  # within noise


def test_a_budget_is_planned_from_frames_not_from_the_clock():
    from d2sr.train.adapt import COSTS, MIN_STEPS, VARIANTS, Plan

    p8 = Plan.of(8, 80, 20)  # the default budget on 100 frames: every copy, the rest trains
    assert p8.variants == VARIANTS and p8.seconds <= 8 * 60 + COSTS.step
    p1 = Plan.of(1, 80, 20)
    assert p1.variants < VARIANTS and p1.steps >= MIN_STEPS and p1.seconds <= 60 * 1.5
    assert Plan.of(1, 80, 20) == p1  # nothing but the budget and the frames decide it
    big = Plan.of(1, 5000, 1000)
    assert big.variants == 1 and big.steps == MIN_STEPS and big.seconds > 60  # over budget, and it says so


def test_threshold_takes_the_widest_margin_and_else_the_false_alarm_target():
    from d2sr.contract.catalog import THRESHOLD
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
