"""d2sr detect / recover / export on PNG folders: outputs, the copy-unless-flagged rule, both backends,
and bad inputs (one line, exit 2, nothing written)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.contract.catalog import padded
from d2sr.contract.repair import repair_frame
from d2sr.frames.png import encode_png
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings
from helpers import d2sr


def _folder(root: Path, n=3, shape=(96, 128), scale=1000) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(n):
        d = (rng.uniform(1.0, 4.0, shape) * scale).astype(np.uint16)
        d[rng.random(shape) < 0.4] = 0
        (root / f"f{i:03d}.png").write_bytes(encode_png(d, "x"))
    return root


def _png(p: Path) -> np.ndarray:
    return cv2.imread(str(p), cv2.IMREAD_UNCHANGED)


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_detect_writes_the_fixed_csv(tmp_path, weights, backend):
    src = _folder(tmp_path / "in")
    res = d2sr(
        "detect", str(src), "--out", str(tmp_path / "d.csv"), "--models", str(weights), "--backend", backend
    )
    assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader((tmp_path / "d.csv").open()))
    assert [r["frame"] for r in rows] == ["f000", "f001", "f002"]
    for r in rows:
        assert 0 <= float(r["score"]) <= 1 and r["interfered"] == str(int(float(r["score"]) >= 0.5))


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_backends_agree(tmp_path, weights):
    src = _folder(tmp_path / "in")
    out = {}
    for b in ("onnx", "torch"):
        assert (
            d2sr(
                "detect",
                str(src),
                "--out",
                str(tmp_path / f"{b}.csv"),
                "--models",
                str(weights),
                "--backend",
                b,
            ).returncode
            == 0
        )
        out[b] = [float(r["score"]) for r in csv.DictReader((tmp_path / f"{b}.csv").open())]
    np.testing.assert_allclose(out["onnx"], out["torch"], atol=1e-4)


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_recover_all_changes_only_masked_pixels(tmp_path, weights):
    src = _folder(tmp_path / "in", 7)
    out = tmp_path / "out"
    res = d2sr("recover", str(src), "--out", str(out), "--repair", "all", "--models", str(weights))
    assert res.returncode == 0, res.stderr
    meta = json.loads((out / "meta.json").read_text())
    assert meta["depth_scale"] == 1000 and all(f["repaired"] for f in meta["frames"])
    for f in sorted(src.glob("*.png")):
        raw, fixed, mask = _png(f), _png(out / f.name), _png(out / "masks" / f.name)
        assert fixed.dtype == np.uint16 and mask.dtype == np.uint8 and set(np.unique(mask)) <= {0, 255}
        assert np.array_equal(fixed[mask == 0], raw[mask == 0])
    # --repair all repairs several frames at a time: the same frames, in the same order, as one at a time
    net = open_backend(RunSettings(model="unet8", backend="onnx", models=weights, threads=2), detector=False)
    for f in sorted(src.glob("*.png")):
        raw = _png(f)
        pred, m = net.recover(padded(raw.astype(np.float32)[None] / np.float32(1000)))
        h, w = raw.shape
        fixed, mask = repair_frame(raw, pred[0, :h, :w], m[0, :h, :w], 1000)
        assert np.array_equal(_png(out / f.name), fixed)
        assert np.array_equal(_png(out / "masks" / f.name) > 0, mask)
    assert [r["name"] for r in meta["frames"]] == sorted(f.stem for f in src.glob("*.png"))
    # --repair all asks no detector: a folder holding only the recovery model repairs the same
    alone = tmp_path / "alone"
    alone.mkdir()
    for f in weights.glob("unet8.*"):
        shutil.copy(f, alone / f.name)
    res = d2sr("recover", str(src), "--out", str(tmp_path / "o2"), "--repair", "all", "--models", str(alone))
    assert res.returncode == 0, res.stderr
    for f in sorted(src.glob("*.png")):
        assert np.array_equal(_png(tmp_path / "o2" / f.name), _png(out / f.name))
    res = d2sr("recover", str(src), "--out", str(tmp_path / "o3"), "--models", str(alone))
    assert res.returncode == 2 and "detector" in res.stderr and not (tmp_path / "o3").exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_recover_auto_takes_the_temporal_model_where_the_sequence_lines_up(tmp_path, weights):
    import torch

    from d2sr.desync import make_controller
    from d2sr.frames import Frame
    from d2sr.models import build
    from d2sr.models.onnx.export import export
    from d2sr.models.store import save_model
    from d2sr.runtime.loop import Capture, SensorLoop

    both = tmp_path / "both"
    shutil.copytree(weights, both)
    torch.manual_seed(1)
    save_model(build("unet8-temporal").eval(), "unet8-temporal", both / "unet8-temporal.safetensors")
    export(both / "unet8-temporal.safetensors", both / "unet8-temporal.onnx")
    # A still sensor for 4 frames (the scene with fresh noise), then another scene for 4.
    src = tmp_path / "in"
    src.mkdir()
    rng = np.random.default_rng(3)
    for k in range(8):
        scene = np.random.default_rng(k // 4).uniform(1.0, 4.0, (96, 128))
        d = ((scene + rng.normal(0, 0.005, scene.shape)) * 1000).astype(np.uint16)
        d[rng.random(d.shape) < 0.2] = 0
        (src / f"f{k:03d}.png").write_bytes(encode_png(d, "x"))
    for name, folder in (("auto", both), ("unet8", both), ("fallback", weights)):
        model = "unet8" if name == "unet8" else "auto"
        res = d2sr(
            "recover",
            str(src),
            "--out",
            str(tmp_path / name),
            "--repair",
            "all",
            "--models",
            str(folder),
            "--model",
            model,
        )
        assert res.returncode == 0, res.stderr
    files = sorted(src.glob("*.png"))
    # Without unet8-temporal in the folder (d2sr adapt's), auto is unet8.
    for f in files:
        assert np.array_equal(_png(tmp_path / "fallback" / f.name), _png(tmp_path / "unet8" / f.name))
    # The same frames as the runtime's loop repairing one at a time, in order, its detector run only where
    # it can change the last clean frame (recover --repair all with a temporal model); both models were used.
    net = open_backend(RunSettings(backend="onnx", models=both, threads=2))
    used = {"single": 0, "temporal": 0}

    def counted(side: str):
        run = getattr(net, side).recover

        def recover(x, p):
            used[side] += 1
            return run(x, p)

        return recover

    for side in used:
        getattr(net, side).recover = counted(side)
    loop = SensorLoop(
        net,
        make_controller("static", 30, 30),
        judge_every=False,
        settings=RunSettings(repair="all", scene=False),
    )
    for f in files:
        r = loop.process(Capture(Frame(f.stem, _png(f)), 1000.0))
        assert np.array_equal(_png(tmp_path / "auto" / f.name), r.depth)
        assert np.array_equal(_png(tmp_path / "auto" / "masks" / f.name) > 0, r.mask)
    assert used["single"] > 0 and used["temporal"] > 0, used


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_mask_logit_trades_masked_pixels(tmp_path, weights, backend):
    src = _folder(tmp_path / "in", 1)
    masked = []
    for logit in ("8", "-8"):
        out = tmp_path / f"o{logit}"
        args = ("--repair", "all", "--models", str(weights), "--backend", backend, "--mask-logit", logit)
        assert d2sr("recover", str(src), "--out", str(out), *args).returncode == 0
        masked.append(int((_png(out / "masks" / "f000.png") > 0).sum()))
    assert masked[0] < masked[1]
    res = d2sr(
        "recover", str(src), "--out", str(tmp_path / "bad"), "--models", str(weights), "--mask-logit", "nan"
    )
    assert res.returncode == 2 and "--mask-logit" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad").exists()
    bad = ("--out", str(tmp_path / "bad"), "--models", str(weights), "--passes", "0")
    res = d2sr("recover", str(src), *bad)
    assert res.returncode == 2 and "--passes" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad").exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_recover_copies_frames_the_detector_does_not_flag(tmp_path, weights):
    src = _folder(tmp_path / "in")
    out = tmp_path / "out"
    res = d2sr("recover", str(src), "--out", str(out), "--threshold", "0.999999", "--models", str(weights))
    assert res.returncode == 0, res.stderr
    for f in sorted(src.glob("*.png")):
        assert np.array_equal(_png(out / f.name), _png(f))
        assert not _png(out / "masks" / f.name).any()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_frames_of_any_size_are_padded_for_the_models_and_cropped_back(tmp_path, weights):
    src = _folder(tmp_path / "in", 2, shape=(100, 130))  # 32 divides neither side
    res = d2sr("recover", str(src), "--out", str(tmp_path / "o"), "--repair", "all", "--models", str(weights))
    assert res.returncode == 0, res.stderr
    for f in sorted(src.glob("*.png")):
        out, mask = _png(tmp_path / "o" / f.name), _png(tmp_path / "o" / "masks" / f.name)
        assert out.shape == mask.shape == (100, 130)
        assert np.array_equal(out[mask == 0], _png(f)[mask == 0])
    res = d2sr("detect", str(src), "--out", str(tmp_path / "d.csv"), "--models", str(weights))
    assert res.returncode == 0, res.stderr


BAD = {
    "empty folder": (lambda p: p.mkdir() or p, "no PNG depth frames"),
    "corrupt png": (
        lambda p: _folder(p, 2) and (p / "f001.png").write_bytes(b"\x89PNG\r\n\x1a\nxxxxIEND") and p,
        "f001",
    ),
    "8-bit png": (
        lambda p: p.mkdir() or (cv2.imwrite(str(p / "a.png"), np.ones((96, 128), np.uint8)) and p),
        "8-bit PNG",
    ),
    "wrong scale": (lambda p: _folder(p, 1, scale=10), "is the scale right"),
}


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
@pytest.mark.parametrize("case", list(BAD))
@pytest.mark.parametrize("command", ["detect", "recover"])
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, weights, case, command):
    make, message = BAD[case]
    src = make(tmp_path / "in")
    out = tmp_path / ("o.csv" if command == "detect" else "o")
    res = d2sr(
        command,
        str(src),
        "--out",
        str(out),
        "--models",
        str(weights),
        *(("--repair", "all") if command == "recover" else ("--threshold=0.5",)),
    )
    assert res.returncode == 2, res.stderr
    assert (
        message in res.stderr and "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    )
    assert not out.exists() and not list(tmp_path.glob(".o*"))


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_nan_depth_and_missing_or_corrupt_weights(tmp_path, weights):
    bad = tmp_path / "nan.npz"
    np.savez(bad, depth=np.full((2, 96, 128), np.nan, np.float32), depth_scale=1.0)
    res = d2sr("detect", str(bad), "--out", str(tmp_path / "o.csv"), "--models", str(weights))
    assert res.returncode == 2 and "NaN" in res.stderr
    src = _folder(tmp_path / "in")
    res = d2sr("detect", str(src), "--out", str(tmp_path / "o.csv"), "--models", str(tmp_path / "none"))
    assert res.returncode == 2 and "no such" in res.stderr
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "detector.onnx").write_bytes(b"garbage")
    res = d2sr(
        "detect", str(src), "--out", str(tmp_path / "o.csv"), "--models", str(broken), "--backend", "onnx"
    )
    assert res.returncode == 2 and "corrupt ONNX" in res.stderr
    res = d2sr("recover", str(src), "--out", str(tmp_path / "o"), "--model", "unet9")
    assert res.returncode == 2 and "--model" in res.stderr
    assert not (tmp_path / "o.csv").exists() and not (tmp_path / "o").exists()
