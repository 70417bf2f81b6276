"""The shipped models: cards complete, ONNX files agree with the safetensors, and they do their job on
held-out generated frames (seeds the training never used)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from d2sr.contract.catalog import DETECTOR_NAMES
from d2sr.contract.catalog import WEIGHTS as SHIPPED
from d2sr.contract.repair import repair_frame
from d2sr.models.store import load_model
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings
from d2sr.sim.dataset import TEST_SEED, synth_frame, synth_sequence_frame

NAMES = sorted(p.stem for p in SHIPPED.glob("*.safetensors"))


def test_the_defaults_are_shipped():
    assert {"detector", "unet8"} <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_card_says_data_command_metrics_date(name):
    card = json.loads((SHIPPED / f"{name}.card.json").read_text())
    for key in ("data", "command", "metrics", "date", "training"):
        assert card.get(key), key
    assert "generated" in card["data"] and "shared" not in card["data"]
    # The shipped detector is the temporal architecture: the card names what was trained.
    assert card["model"] == name or (name, card["model"]) == ("detector", "detector-temporal")
    assert (SHIPPED / f"{name}.md").read_text().startswith(f"# Model card: {card['model']}")
    assert (SHIPPED / f"{name}.safetensors").stat().st_size < 10_000_000  # small


@pytest.mark.parametrize("name", NAMES)
def test_onnx_matches_weights(name):
    from d2sr.models.onnx.export import parity

    model, got = load_model(SHIPPED / f"{name}.safetensors")
    assert got == json.loads((SHIPPED / f"{name}.card.json").read_text())["model"]
    s = synth_sequence_frame(TEST_SEED + 1, True, previous=True)
    ins = [s.frame, s.previous][: getattr(model, "frames", 1)]  # a temporal model: also the last clean frame
    x = torch.from_numpy(np.stack(ins).astype(np.float32)[None] / s.scale)
    # As the runtime runs the files (a temporal model's streaming form: d2sr.models.streaming).
    assert parity(model, name in DETECTOR_NAMES, SHIPPED / f"{name}.onnx", x)["max_abs_diff"] < 2e-3


@pytest.fixture(scope="module")
def frames() -> list[tuple[np.ndarray, np.ndarray, np.ndarray, float, bool]]:
    """(frame in metres, clean in metres, frame uint16, scale, interfered) of held-out generated frames: 4
    clean, 4 interfered on at least 1% of their pixels (what the detector is trained to see)."""
    out: list[tuple[np.ndarray, np.ndarray, np.ndarray, float, bool]] = []
    i = 0
    while len(out) < 8:
        bad = len(out) % 2 == 1
        f, c, s = synth_frame(TEST_SEED + 100 + i, bad)
        i += 1
        if bad and (f != c).mean() < 0.01:
            continue
        out.append((f.astype(np.float32) / s, c.astype(np.float32) / s, f, s, bad))
    return out


def test_shipped_detector_separates_held_out_frames(frames):
    net = open_backend(recovery=False)
    scores = [float(net.scores(x[None])[0]) for x, *_ in frames]
    labels = np.array([lab for *_, lab in frames])
    flagged = np.array(scores) >= net.threshold
    # No clean frame flagged; its measured recall on generated frames is ~0.77, so 3 of the 4 at least.
    assert not flagged[~labels].any() and flagged[labels].sum() >= 3, scores


def test_shipped_unet8_lowers_the_error_of_held_out_frames_taken_together():
    """40 held-out generated frames interfered on at least 1% of their pixels: the squared error over all of
    them falls by at least a quarter, at most 1 frame in 4 ends worse, and no pixel outside the predicted
    mask is touched. Single frames can end worse (measured 2026-11-26: 7 of 40, the worst 4.1x on a small
    patch): this test does not claim otherwise."""
    net = open_backend(RunSettings(model="unet8"))
    before = after = 0.0
    worse = seen = i = 0
    while seen < 40:
        f, c, scale = synth_frame(TEST_SEED + 100 + i, True)
        i += 1
        if (f != c).mean() < 0.01:
            continue
        seen += 1
        x, clean = f.astype(np.float32) / scale, c.astype(np.float32) / scale
        pred, mask = net.recover(x[None])
        out, kept = repair_frame(f, pred[0], mask[0], scale)
        assert np.array_equal(out[~kept], f[~kept]) and not (kept & ~mask[0]).any()
        valid = clean > 0
        b = float(((x - clean)[valid] ** 2).sum())
        a = float(((out.astype(np.float32) / scale - clean)[valid] ** 2).sum())
        before, after, worse = before + b, after + a, worse + (a > b)
    assert after / before < 0.75 and worse <= 10, (after / before, worse)


@pytest.mark.parametrize("backend", ["torch", "onnx"])
def test_a_recovery_model_opens_alone(backend, frames):
    from d2sr.errors import ConfigError, InputError

    net = open_backend(RunSettings(model="unet8", backend=backend), detector=False)
    x = frames[1][0][None]
    pred, mask = net.recover(x)
    assert pred.shape == mask.shape == x.shape
    with pytest.raises(InputError, match="no detector"):
        net.scores(x)
    with pytest.raises(ConfigError, match="needs a detector"):
        open_backend(RunSettings(backend=backend), detector=False, recovery=False)


def test_every_shipped_file_stays_under_5_mb():
    # The repository stays light: large models are stored in float16 (models.store.HALF_ABOVE).
    big = [f.name for f in SHIPPED.iterdir() if f.stat().st_size > 5 * 2**20]
    assert not big, big


REAL_L515 = Path(__file__).resolve().parents[3] / "shared" / "data" / "l515" / "dev1"


@pytest.fixture(scope="module")
def int8_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped detector and unet8 beside their int8 forms (``d2sr export --int8``'s quantizer)."""
    import shutil

    from d2sr.contract.catalog import model_files
    from d2sr.models.onnx.quantize import quantize

    folder = tmp_path_factory.mktemp("int8")
    for name in ("detector", "unet8"):
        for f in model_files(SHIPPED, name):
            shutil.copyfile(f, folder / f.name)
        quantize(folder / f"{name}.onnx")
    return folder


def _frames_4000(n: int) -> list[tuple[np.ndarray, np.ndarray | None]]:
    out: list[tuple[np.ndarray, np.ndarray | None]] = []
    for i in range(n):
        f, c, s = synth_frame(TEST_SEED + 500 + i, bool(i % 2))
        f, c = (
            np.clip(np.rint(a.astype(np.float64) * (4000 / s)), 0, 65535).astype(np.uint16) for a in (f, c)
        )
        out.append((f, c if i % 2 else None))
    return out


def test_int8_stays_experimental_while_it_misses_its_tolerance_against_fp32(int8_folder):
    """int8 is offered as experimental (``--int8``) because it misses ``TOLERANCE`` against fp32 (verdicts
    differing on at most 5% of frames, repair RMSE at most 5% above): on 20 held-out generated frames, and
    on real L515 frames where ../shared/data is present (lab/int8_real.py). When it meets the tolerance,
    this fails: then the docs and ``--int8``'s help must stop calling it experimental."""
    from d2sr.models.onnx.quantize import agreement, within_tolerance

    got = agreement(int8_folder, _frames_4000(20), 4000.0)
    assert got["frames"] == 20 and got["rmse_cm"]["fp32"] > 0
    assert not within_tolerance(got), got
    if REAL_L515.is_dir():
        import cv2
        from bench.outside.sets_a_i import outside_interference  # the outside set A interference

        files = sorted(REAL_L515.glob("*.png"))[:20]
        real = []
        for i, f in enumerate(files):
            clean = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
            real.append((outside_interference(clean, 4000.0, 7 + i), clean) if i % 2 else (clean, None))
        assert not within_tolerance(agreement(int8_folder, real, 4000.0))
