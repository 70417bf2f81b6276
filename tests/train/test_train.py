"""Training: settings checks, a seeded run is reproducible and resumes exactly, DDP on two gloo processes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from d2sr.errors import ConfigError
from d2sr.models.store import mask_logit, read_card, write_card
from d2sr.sim.dataset import synth_frame
from d2sr.train.config import TrainSettings
from d2sr.train.data import Augment, Batch, Pool, Source, mirror_pattern, synth_set, warp_interference
from d2sr.train.loop import MASK_LOGITS, MAX_CLEAN_CHANGED, as_second_pass, lineage, loss_fn, train
from helpers import d2sr


def _cfg(tmp: Path, **kw) -> TrainSettings:
    base = dict(
        task="recovery",
        model="unet8",
        steps=4,
        batch=2,
        crop=(64, 96),
        synthetic=4,
        cache=tmp / "cache",
        checkpoint_every=2,
        validation=4,
    )
    return TrainSettings.make(**(base | kw))


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_config_rejects_what_cannot_work(tmp_path):
    with pytest.raises(ConfigError, match="task detector takes one of"):
        _cfg(tmp_path, task="detector", model="unet8")
    with pytest.raises(ConfigError, match="unknown model"):
        _cfg(tmp_path, model="unet7")
    with pytest.raises(ConfigError, match="multiples of 32"):
        _cfg(tmp_path, crop=(60, 96))
    with pytest.raises(ConfigError, match="no data"):
        _cfg(tmp_path, synthetic=0)
    with pytest.raises(ConfigError, match="steps"):
        _cfg(tmp_path, steps=0)
    with pytest.raises(ConfigError, match="gate_previous is for the temporal"):
        _cfg(tmp_path, model="unet8", gate_previous=True)
    with pytest.raises(ConfigError, match="batch: Input should be less than or equal to 1024"):
        _cfg(tmp_path, batch=10**9)  # hung making a billion indices
    with pytest.raises(ConfigError, match="teacher must be a recovery model's weights file"):
        _cfg(tmp_path, teacher=tmp_path / "missing.safetensors")


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_synthetic_frames_are_a_function_of_their_seed():
    a, ac, sa = synth_frame(11, interfered=True)
    b, bc, sb = synth_frame(11, interfered=True)
    assert np.array_equal(a, b) and np.array_equal(ac, bc) and sa == sb
    assert (a != ac).any()
    c, cc, _ = synth_frame(12, interfered=False)
    assert np.array_equal(c, cc) and c.dtype == np.uint16 and c.shape == (480, 640)


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_batches_are_balanced_cropped_and_consistent(tmp_path):
    ss = synth_set(tmp_path, 4, 0, progress=False)
    assert ss.labels.tolist() == [False, True, False, True]
    pool = Pool.from_config(_cfg(tmp_path, cache=tmp_path), progress=False)
    b = pool.batch(np.random.default_rng(0), 8, (64, 96), clean_share=0.5)
    assert b.x.shape == b.y.shape == b.m.shape == (8, 1, 64, 96)
    assert np.array_equal(b.m > 0, b.x != b.y)  # the mask is exactly the changed pixels
    assert 0 < b.label.sum() < 8


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_temporal_detector_sees_the_previous_frame_as_delivered(tmp_path):
    cfg = _cfg(tmp_path, task="detector", model="detector-temporal", synthetic=6, cache=tmp_path)
    ss = synth_set(tmp_path, 6, 0, progress=False, previous=True)
    pool = Pool.from_config(cfg, progress=False, frames=2)
    rng = np.random.default_rng(0)
    seen = {"itself": 0, "last clean": 0, "hit": 0}
    for _ in range(60):
        i = int(rng.integers(0, 6))
        f, last = np.asarray(ss.frames[i]), np.asarray(ss.previous[i])
        p = pool._previous(rng, f, last)
        assert p.shape == f.shape and p.dtype == np.uint16
        if p is f:
            seen["itself"] += 1
        elif np.array_equal(p, last):
            seen["last clean"] += 1
        else:  # another frame's pattern on the last clean frame: only where that frame was changed
            j = [k for k in range(6) if ss.labels[k] and ((p != last) <= (ss.frames[k] != ss.clean[k])).all()]
            assert j
            seen["hit"] += 1
    assert all(n > 0 for n in seen.values()), seen
    b = pool.batch(rng, 4, None)
    assert b.x.shape == (4, 2, 480, 640) and (b.x[:, 1] > 0).any()


def test_gated_temporal_recovery_gets_no_last_frame_that_does_not_line_up():
    # Frame 0's last clean frame lines up with it (the same wall); frame 1's does not (a wall 2 m farther).
    frames = [np.full((32, 32), 2000, np.uint16), np.full((32, 32), 3000, np.uint16)]
    previous = [frames[0].copy(), np.full((32, 32), 5000, np.uint16)]
    src = Source(frames, frames, None, 1000.0, np.array([True, True]), previous)
    rng = np.random.default_rng(0)
    for gate in (False, True):
        b = Pool([src], frames=2, augment=Augment(gate_previous=gate)).batch(rng, 200, None)
        first = b.x[:, 0].mean(axis=(1, 2)) < 2.4  # gain 0.85-1.15: frame 0 below, frame 1 above
        has_last = (b.x[:, 1] > 0).all(axis=(1, 2))
        assert first.any() and (~first).any()
        assert 0.75 < has_last[first].mean() < 1  # 10% start-up frames have none either way
        assert has_last[~first].any() != gate  # gated: never the wall that is not there any more


def test_clean_previous_detector_sees_its_last_clean_frame_or_itself():
    # Frame 0 (hit: one column halved) has a last clean frame that lines up; frame 1's (a wall 2 m
    # farther) does not, so it is given itself.
    f0, c0 = np.full((32, 32), 2000, np.uint16), np.full((32, 32), 2000, np.uint16)
    f0[:, 5] = 1000
    f1 = np.full((32, 32), 3000, np.uint16)
    previous = [c0.copy(), np.full((32, 32), 5000, np.uint16)]
    src = Source([f0, f1], [c0, f1], None, 1000.0, np.array([True, False]), previous)
    pool = Pool([src], frames=2, raw_previous=True, augment=Augment(clean_previous=True))
    b = pool.batch(np.random.default_rng(0), 200, None)
    hit = b.label == 1
    itself = np.all(b.x[:, 1] == b.x[:, 0], axis=(1, 2))
    assert itself[~hit].all()  # not lined up: the frame itself, never the wall that is not there
    assert 0.05 < itself[hit].mean() < 0.3  # 15% without a sequence
    # Otherwise the clean wall, unhit: never an interfered previous frame.
    assert (b.x[hit & ~itself, 1] == b.y[hit & ~itself, 0]).all()
    with pytest.raises(ValueError, match="clean_previous is for the temporal detector"):
        TrainSettings(task="detector", model="detector", clean_previous=True)


def test_warped_interference_bends_the_pattern_and_keeps_the_scene():
    # Vertical stripes of too-short depth on a ramp; the warp must bend them, not move the scene.
    clean = np.tile(np.linspace(1000, 3000, 96, dtype=np.float32), (64, 1)).astype(np.uint16)
    mask = np.zeros(clean.shape, bool)
    mask[:, 10::16] = mask[:, 11::16] = True
    frame = np.where(mask, clean // 2, clean).astype(np.uint16)
    rng = np.random.default_rng(1)
    out, m = warp_interference(rng, frame, clean, mask)
    assert np.array_equal(m, out != clean)  # the mask is what differs from the scene
    assert np.array_equal(out[~m], clean[~m])  # the scene stays where no interference lands
    assert not np.array_equal(m, mask)  # the stripes moved
    assert abs(m.mean() - mask.mean()) < 0.05  # about as much of the frame is hit
    assert m.any(axis=0).sum() > mask.any(axis=0).sum()  # a straight stripe now spans more columns
    frames = [frame]
    src = Source(frames, [clean], None, 1000.0, np.array([True]))

    def same(b: Batch) -> list[bool]:  # each frame's mask is the pattern as made (or flipped)
        return [np.array_equal(k, mask) or np.array_equal(k, mask[:, ::-1]) for k in b.m[:, 0] > 0]

    assert all(same(Pool([src]).batch(np.random.default_rng(0), 4, None)))  # no warp: the pattern as made
    warped = Pool([src], augment=Augment(warp=1.0)).batch(np.random.default_rng(0), 4, None)
    assert np.array_equal(warped.m > 0, warped.x != warped.y)
    assert not any(same(warped))  # at share 1 every interfered frame is warped
    with pytest.raises(ValueError, match=r"the \*_interference settings are for recovery"):
        TrainSettings(task="detector", model="detector", warp_interference=0.5)


def test_stacked_interference_lays_another_frames_pattern_over_the_scene():
    # Frame 0: a wall at 2 m with one column halved; frame 1: a wall at 4 m with its left half at 3/4 depth.
    c0, c1 = np.full((16, 16), 2000, np.uint16), np.full((16, 16), 4000, np.uint16)
    f0, f1 = c0.copy(), c1.copy()
    f0[:, 12] = 1000
    f1[:, :8] = 3000
    src = Source([f0, f1], [c0, c1], None, 1000.0, np.array([True, True]))
    plain = Pool([src]).batch(np.random.default_rng(0), 40, None)
    stacked = Pool([src], augment=Augment(stack=1.0)).batch(np.random.default_rng(0), 40, None)
    assert np.array_equal(stacked.m > 0, stacked.x != stacked.y)  # the mask is what differs from the scene
    assert stacked.m.mean() > plain.m.mean()  # more of each frame is hit
    # Each pixel is the scene times a ratio of one of the two patterns: 1/2 (frame 0's), 3/4 (frame 1's).
    ratio = np.round(stacked.x / stacked.y, 3)
    assert set(np.unique(ratio)) <= {0.5, 0.75, 1.0}
    # Frame 0 (the 2 m wall: 1.7-2.3 m after the gain) mostly gets frame 1's pattern, the heavier one (8
    # columns hit against 1: drawn 8 times in 9); laying a frame's pattern on itself changes nothing.
    first = stacked.y[:, 0, 0, 0] < 3
    assert 5 <= first.sum() <= 35
    assert ((ratio[first] == 0.75).sum(axis=(1, 2, 3)) >= 7 * 16).mean() > 0.6


def test_mirrored_interference_reads_too_far_by_the_factor_it_read_too_short():
    clean = np.full((8, 8), 2000, np.uint16)
    clean[0] = 0  # no return: a spurious one stays as it is
    frame = clean.copy()
    frame[1], frame[2], frame[3], frame[0, :2] = 1000, 0, 2500, 700  # too short, dropout, too far, spurious
    out = mirror_pattern(frame, clean)
    assert (out[1] == 4000).all() and (out[2] == 0).all() and (out[3] == 1600).all()
    assert (out[0, :2] == 700).all() and np.array_equal(out[4:], clean[4:])
    assert np.array_equal(out != clean, frame != clean)  # the same pixels hit
    near = np.full((4, 4), 60000, np.uint16)
    assert (mirror_pattern(near // 2, near) == 65535).all()  # beyond the unit's range: its top
    src = Source([frame, clean], [clean, clean], None, 1000.0, np.array([True, False]))
    b = Pool([src], augment=Augment(mirror=1.0)).batch(np.random.default_rng(0), 20, None, clean_share=0.5)
    hit = b.label == 1
    assert hit.any() and (~hit).any()
    # Every interfered frame is mirrored at share 1: its too-short row now reads twice the scene's depth.
    rows = b.x[hit][:, 0, 1]
    assert np.allclose(rows / b.y[hit][:, 0, 1], 2.0, atol=1e-3)
    assert np.array_equal(b.m > 0, b.x != b.y)
    assert np.array_equal(b.x[~hit], b.y[~hit])  # clean frames untouched
    with pytest.raises(ValueError, match=r"the \*_interference settings are for recovery"):
        TrainSettings(task="detector", model="detector", mirror_interference=0.5)


def test_shell_interference_follows_the_scenes_depth_not_a_shape():
    from d2sr.sim.families import shell_interference

    # Four walls side by side at 1, 2, 3 and 4 m: a shell of depth takes whole walls, never part of one.
    d = np.repeat(np.array([1.0, 2.0, 3.0, 4.0], np.float32), 16)[None].repeat(32, 0)
    spans = []
    for seed in range(20):
        new, where = shell_interference(d, np.random.default_rng(seed))
        assert np.array_equal(new[~where], d[~where])  # only the pattern's pixels change
        walls = {float(v) for v in np.unique(d[where])}
        spans.append(len(walls))
        assert walls <= {1.0, 2.0, 3.0, 4.0} and (not walls or max(walls) - min(walls) <= len(walls) - 1)
    assert 1 <= np.median(spans) < 4  # a shell, not the whole frame
    clean = (d * 1000).astype(np.uint16)
    frame = clean.copy()
    frame[:, 0] = 500  # the frame's own pattern: the first column, which must stay as it is
    src = Source([frame], [clean], None, 1000.0, np.array([True]))
    b = Pool([src], augment=Augment(shell=1.0)).batch(np.random.default_rng(0), 8, None)
    assert np.array_equal(b.m > 0, b.x != b.y)
    assert (b.m.sum(axis=(1, 2, 3)) > 32).mean() > 0.5  # most frames gain a shell's pixels
    assert (np.round(b.x / np.maximum(b.y, 1e-6), 2) == 0.5).any()  # the own pattern (0.5x) survives
    with pytest.raises(ValueError, match=r"the \*_interference settings are for recovery"):
        TrainSettings(task="detector", model="detector", shell_interference=0.5)


class _Fixed(torch.nn.Module):
    """A "model" whose outputs are its parameters, to read the loss's gradient per pixel."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        super().__init__()
        self.logit = torch.nn.Parameter(torch.zeros(shape))
        self.pred = torch.nn.Parameter(torch.full(shape, 2.0))

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.logit, self.pred


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_depth_is_learned_only_where_the_ground_truth_has_a_return():
    x = np.zeros((1, 1, 2, 3), np.float32)  # every pixel a dropout
    y = np.array([[[[3.0, 3.0, 0.0], [3.0, 0.0, 0.0]]]], np.float32)
    m = (y > 0).astype(np.float32)
    m[0, 0, 1, 2] = 1  # interfered, but no return in the ground truth either
    model = _Fixed(x.shape)
    loss_fn(model, "recovery", Batch(x, y, m, np.ones(1, np.float32)), torch.device("cpu")).backward()
    g = model.pred.grad[0, 0].abs()
    assert (g[y[0, 0] > 0] > 0).all()
    assert (g[y[0, 0] == 0] == 0).all()
    # The mask head is pushed to flag the dropouts over real surfaces hardest: missing them costs depth.
    lg = model.logit.grad[0, 0]
    assert (lg[y[0, 0] > 0] < lg[1, 2]).all()


def test_mask_error_weight_pushes_hardest_on_the_costliest_misses():
    # Three interfered pixels off by 0.05, 0.5 and 3 m (capped at 2), one clean pixel; the mask says 0.5.
    x = np.array([[[[2.95, 2.5, 0.0, 2.0]]]], np.float32)
    y = np.full((1, 1, 1, 4), 3.0, np.float32)
    y[0, 0, 0, 3] = 2.0
    m = np.array([[[[1, 1, 1, 0]]]], np.float32)
    b = Batch(x, y, m, np.ones(1, np.float32))

    def logit_grad(k: float) -> np.ndarray:
        model = _Fixed(x.shape)
        loss_fn(model, "recovery", b, torch.device("cpu"), dice=0.0, error_weight=k).backward()
        return model.logit.grad[0, 0, 0].numpy()

    # What the weighting adds to the mask's gradient (the depth terms are the same in both runs).
    extra = logit_grad(2.0) - logit_grad(0.0)
    assert extra[2] < extra[1] < extra[0]  # the bigger the error, the harder the push to flag
    assert abs(extra[:3].sum()) < 1e-6  # the interfered pixels' total weight stays
    assert extra[3] == 0  # the clean pixel is untouched
    with pytest.raises(ValueError, match="mask_error_weight"):
        TrainSettings(task="recovery", model="unet8", mask_error_weight=-1)


class _Shorter(torch.nn.Module):
    """Flags every return nearer than 1.5 m and predicts 2 m everywhere."""

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        near = (x[:, :1] > 0) & (x[:, :1] < 1.5)
        return torch.where(near, 5.0, -5.0), torch.full_like(x[:, :1], 2.0)


def test_second_pass_inputs_are_what_recover_feeds_its_second_pass():
    x = np.full((3, 2, 32, 48), 2.0, np.float32)  # a wall at 2 m; channel 1 stands for an earlier frame
    x[:, :, 10:14] = 1.0  # a too-short stripe
    y = np.full((3, 1, 32, 48), 2.0, np.float32)
    m = (x[:, :1] != y).astype(np.float32)
    b = Batch(x, y, m, np.array([1, 0, 1], np.float32))  # the middle frame is labelled clean
    model = _Shorter().train()
    same = as_second_pass(model, b, 0.0, 0.0, np.random.default_rng(0), torch.device("cpu"))
    assert same is b
    out = as_second_pass(model, b, 1.0, 0.0, np.random.default_rng(0), torch.device("cpu"))
    assert model.training  # back in training mode
    assert np.array_equal(b.x, x)  # the batch it was given is left as it was
    for i in (0, 2):  # interfered: the stripe holds the guarded first repair, everything else as it was
        assert np.all(out.x[i, 0] == 2.0)
    assert np.array_equal(out.x[1], x[1])  # clean frames are trained on as delivered
    assert np.array_equal(out.x[:, 1], x[:, 1])  # an earlier frame is never rewritten
    assert out.y is b.y and out.m is b.m  # targets: the clean frame and the true mask, as before


def test_a_teacher_gives_interfered_frames_its_repair_and_clean_ones_the_truth():
    from d2sr.models.inference import TorchBackend
    from d2sr.train.loop import taught

    x = np.full((2, 1, 32, 48), 2.0, np.float32)  # a wall at 2 m
    x[:, :, 10:14] = 1.0  # a too-short stripe
    y = np.full((2, 1, 32, 48), 2.0, np.float32)
    m = (x != y).astype(np.float32)
    m[0, 0, 12:14] = 0  # the truth misses half the stripe in frame 0; the teacher does not
    b = Batch(x, y, m, np.array([1, 0], np.float32))  # frame 1 is labelled clean
    out = taught(TorchBackend(None, _Shorter(), mask_logit=0.0, passes=1), b)
    assert out.taught is not None and out.m is b.m and out.y is b.y
    tm, ty = out.taught
    assert np.array_equal(tm[0, 0], x[0, 0] < 1.5)  # the teacher's (guarded) repair, the whole stripe
    assert np.all(ty[0] == 2.0)  # its depth where it repairs, the frame's elsewhere
    assert np.array_equal(tm[1], m[1]) and np.array_equal(ty[1], y[1])  # clean: the truth
    # With a teacher weight the mask is pushed to flag the teacher's half of the stripe too.

    def logit_grad(weight: float) -> torch.Tensor:
        model = _Fixed(x.shape)
        loss_fn(model, "recovery", out, torch.device("cpu"), dice=0.0, teacher_weight=weight).backward()
        return model.logit.grad

    extra = logit_grad(1.0) - logit_grad(0.0)
    assert (extra[0, 0, 12:14] < 0).all() and (extra[0, 0, 14:] > 0).all()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_run_is_reproducible_and_resume_is_exact(tmp_path):
    cfg = _cfg(tmp_path)
    train(cfg, tmp_path / "a", progress=False)
    train(cfg, tmp_path / "b", progress=False)
    wa = load_file(tmp_path / "a" / "unet8.safetensors")
    wb = load_file(tmp_path / "b" / "unet8.safetensors")
    assert all(torch.equal(wa[k], wb[k]) for k in wa)
    # Stop after 2 steps (as if killed), then resume to 4: the same weights as one straight run.
    half = _cfg(tmp_path, steps=4, time_limit_min=1e-9)
    train(half, tmp_path / "c", progress=False)
    state = torch.load(tmp_path / "c" / "checkpoint.pt", weights_only=False)
    assert state["step"] == 1
    state["config"] = cfg.model_dump(mode="json")  # the same run, now without the time limit
    torch.save(state, tmp_path / "c" / "checkpoint.pt")
    train(cfg, tmp_path / "c", progress=False)
    wc = load_file(tmp_path / "c" / "unet8.safetensors")
    assert all(torch.equal(wa[k], wc[k]) for k in wa)
    # The resumed run's loss curve is the whole run's, not only the part after the resume.
    la, lc = (json.loads((tmp_path / x / "loss.json").read_text()) for x in "ac")
    assert len(la) == len(lc) == 4 and np.allclose(la, lc)
    card = read_card(tmp_path / "a" / "unet8.safetensors")
    assert card["model"] == "unet8" and "generated" in card["data"] and card["training"]["steps"] == 4
    # The mask threshold chosen on validation frames travels with the weights (and into ONNX on export).
    chosen = card["training"]["mask_threshold"]
    assert (
        chosen["mask_logit"] in MASK_LOGITS
        and mask_logit(tmp_path / "a" / "unet8.safetensors") == chosen["mask_logit"]
    )
    # ... for the repair recover writes (its passes), not only the one-pass curve
    kept = chosen["as_recovered"]["clean_changed"] <= MAX_CLEAN_CHANGED
    assert kept or chosen["mask_logit"] == MASK_LOGITS[0]
    assert "2 passes" in chosen["rule"]
    assert (tmp_path / "a" / "unet8.md").read_text().startswith("# Model card: unet8")


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_detector_trains_and_loss_falls(tmp_path):
    cfg = _cfg(tmp_path, task="detector", model="detector", steps=30, batch=4, synthetic=8, lr=3e-3)
    summary = train(cfg, tmp_path / "d", progress=False)
    losses = json.loads((tmp_path / "d" / "loss.json").read_text())
    assert summary["steps"] == 30
    assert np.mean(losses[-10:]) < np.mean(losses[:10])


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_ddp_on_two_gloo_processes_matches_itself(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        'model = "unet8"\nsteps = 3\nbatch = 2\ncrop = [64, 96]\nsynthetic = 4\n'
        f'cache = "{tmp_path / "cache"}"\n'
    )
    env = os.environ | {"OMP_NUM_THREADS": "1"}
    cmd = [
        sys.executable,
        "-m",
        "torch.distributed.run",
        "--nproc-per-node=2",
        "--standalone",  # a rendezvous on a port the OS picks: no fixed port to collide with
        "-m",
        "d2sr",
        "train",
        "recovery",
        "--config",
        str(cfg),
        "--out",
        str(tmp_path / "ddp"),
    ]
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300, check=False)
    assert res.returncode == 0, res.stderr[-2000:]
    card = read_card(tmp_path / "ddp" / "unet8.safetensors")
    assert card["training"]["processes"] == 2 and card["training"]["steps"] == 3


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_cli_train_bad_config_is_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("steps = [")
    res = d2sr("train", "recovery", "--config", str(bad), "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and "not valid TOML" in res.stderr and "Traceback" not in res.stderr
    res = d2sr("train", "detector", "--model", "unet8", "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and "task detector takes one of" in res.stderr
    assert not (tmp_path / "o" / "detector.safetensors").exists()


def test_a_fine_tune_card_names_the_whole_chain_it_started_from(tmp_path):
    first, second = tmp_path / "a" / "unet8.safetensors", tmp_path / "b" / "unet8.safetensors"
    for p in (first, second):
        p.parent.mkdir()
    write_card(first, command="d2sr train recovery --config a.toml", training={"steps": 5, "minutes": 1.5})
    write_card(second, command="d2sr train recovery --config b.toml", training={"steps": 7, "minutes": 2.0},
               started_from=lineage(first))  # fmt: skip
    chain = lineage(second)
    assert chain["command"].endswith("b.toml") and chain["minutes"] == 2.0 and chain["steps"] == 7
    assert chain["started_from"] == {"weights": str(first), "command": "d2sr train recovery --config a.toml",
                                     "steps": 5, "minutes": 1.5}  # fmt: skip
    assert lineage(tmp_path / "none.safetensors") == {"weights": str(tmp_path / "none.safetensors")}


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_a_fitted_sensor_changes_the_l515_frames_only_and_keeps_its_own_data_set(tmp_path):
    from d2sr.sim.dataset import synth_sequence_frame
    from d2sr.sim.rooms import L515

    dim = L515.model_copy(update={"signal_ref": L515.signal_ref * 20})  # far fewer returns
    kinds: dict[str, int] = {}
    for seed in range(40):
        kinds.setdefault(synth_sequence_frame(seed, False, previous=False).kind, seed)
        if "l515" in kinds and len(kinds) > 1:
            break
    for kind, seed in kinds.items():
        shipped = synth_sequence_frame(seed, False, previous=False).frame
        fitted = synth_sequence_frame(seed, False, previous=False, sensor=dim).frame
        if kind == "l515":
            assert (fitted == 0).mean() > (shipped == 0).mean() + 0.05
        else:
            assert np.array_equal(fitted, shipped)
    plain = synth_set(tmp_path, 2, 0, progress=False)
    assert synth_set(tmp_path, 2, 0, progress=False, sensor=L515).meta == plain.meta
    other = synth_set(tmp_path, 2, 0, progress=False, sensor=dim)
    assert other.meta["sensor"]["signal_ref"] == dim.signal_ref
    assert len(list(tmp_path.iterdir())) == 2

    fit = tmp_path / "calibration.json"
    fit.write_text(json.dumps({"model": dim.model_dump()}))
    assert _cfg(tmp_path, sensor=fit).sensor_model() == dim
    fit.write_text("{}")
    with pytest.raises(ConfigError, match=r"not a calibration\.json"):
        _cfg(tmp_path, sensor=fit)
