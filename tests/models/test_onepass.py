"""The one-pass recovery model (unet8-fast): unet8's trunk at half resolution, a head per 2x2 phase, its
start from unet8, its export and its own passes."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from d2sr.contract.catalog import CATALOG, FAST_RECOVERY
from d2sr.errors import InputError
from d2sr.models.onepass import OnePassUNet, grid_pad, phase_channels, repeat2
from d2sr.models.onnx.export import export
from d2sr.models.registry import build, own_passes
from d2sr.models.store import save_model, warm_start
from d2sr.models.unet import UNet, space_to_depth


def _frame(shape: tuple[int, ...], seed: int = 0) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.rand(*shape, generator=g) * 3 + 0.3


def test_phase_channels_hold_every_second_pixel_as_unet8s_fold_does():
    x = torch.arange(2 * 1 * 16 * 24, dtype=torch.float32).reshape(2, 1, 16, 24)
    folded = space_to_depth(x, 8, 1)
    for a in range(2):
        for b in range(2):
            got = folded[:, phase_channels(a, b)]
            assert torch.equal(got, F.pixel_unshuffle(x[..., a::2, b::2], 4))
    every = sorted(c for a in range(2) for b in range(2) for c in phase_channels(a, b))
    assert every == list(range(64))


def test_it_starts_as_unet8_on_every_second_pixel(tmp_path):
    unet8 = UNet(8, s2d=4, fill=True).eval()
    w = tmp_path / "unet8.safetensors"
    save_model(unet8, "unet8", w, mask_logit=0.0)
    net = build(FAST_RECOVERY).eval()
    assert warm_start(net, w)["copied"] == len(net.state_dict())
    x = _frame((2, 1, 96, 128))
    x[..., ::6, ::10] = 0  # holes: each phase's head sees whether its pixels return, as unet8's does
    with torch.no_grad():
        logit, pred = net(x)
        want_logit, want_pred = unet8(grid_pad(x[..., ::2, ::2], 32))  # 48 rows padded to 64
    assert logit.shape == pred.shape == x.shape
    torch.testing.assert_close(logit[..., ::2, ::2], want_logit[..., :48, :], atol=1e-4, rtol=0)
    torch.testing.assert_close(pred[..., ::2, ::2], want_pred[..., :48, :], atol=1e-4, rtol=0)
    # every phase starts with unet8's head: a flat wall reads alike at all four
    wall = torch.full((1, 1, 64, 96), 2.0)
    with torch.no_grad():
        logit, _ = net(wall)
    block = logit[0, 0, 16:48, 16:80]
    assert (block - block[::2, ::2].repeat_interleave(2, 0).repeat_interleave(2, 1)).abs().max() < 1e-4


def test_only_unet8s_layout_starts_it():
    with pytest.raises(InputError, match="only unet8's layout"):
        build(FAST_RECOVERY).start_from(UNet(16, s2d=4, fill=True))
    with pytest.raises(InputError, match="only unet8's layout"):
        build(FAST_RECOVERY).start_from(UNet(8, s2d=4, fill=True, frames=2))


def test_each_pixel_decides_for_itself(tmp_path):
    unet8 = UNet(8, s2d=4, fill=True).eval()
    w = tmp_path / "unet8.safetensors"
    save_model(unet8, "unet8", w, mask_logit=0.0)
    net = build(FAST_RECOVERY).eval()
    warm_start(net, w)  # the trunk then sees phase (0, 0) only: a change elsewhere reaches only its own head
    x = _frame((1, 1, 64, 96), seed=1)
    y = x.clone()
    y[0, 0, 33, 41] = 0.5  # one pixel of phase (1, 1) read short
    with torch.no_grad():
        a, _ = net(x)
        b, _ = net(y)
    changed = (a != b)[0, 0]
    assert changed[33, 41] and changed[32:40, 40:48].sum() == 16  # its phase's 16 pixels in its block
    assert changed.sum() == 16 and not changed[32, 40]
    # the stem lets the trunk see every pixel once trained: then the block's context moves too
    with torch.no_grad():
        net.stem[0].weight.normal_(0, 0.3)
        a, _ = net(x)
        b, _ = net(y)
    assert (a != b)[0, 0].sum() > 16


def test_grid_pad_and_repeat():
    padded = grid_pad(torch.ones(1, 1, 40, 48), 32)
    assert padded.shape == (1, 1, 64, 64) and padded[..., 40:, :].eq(0).all() and padded[..., 48:].eq(0).all()
    assert grid_pad(torch.ones(1, 1, 64, 32), 32).shape == (1, 1, 64, 32)  # nothing added when it divides
    x = torch.rand(1, 1, 3, 4)
    assert torch.equal(repeat2(x)[..., 1::2, ::2], x)


def test_one_pass_model_shapes_passes_and_export_at_every_size(tmp_path):
    import onnx
    import onnxruntime as ort

    net = build(FAST_RECOVERY)
    assert isinstance(net, OnePassUNet) and net.stride == 32
    assert own_passes(net) == CATALOG[FAST_RECOVERY].passes == 1
    assert own_passes(build("unet8")) == 2
    weights = tmp_path / f"{FAST_RECOVERY}.safetensors"
    save_model(net, FAST_RECOVERY, weights, mask_logit=0.5)
    got = export(weights, tmp_path / f"{FAST_RECOVERY}.onnx")  # refuses when onnxruntime differs
    assert got["max_abs_diff"] < 1e-3
    path = str(tmp_path / f"{FAST_RECOVERY}.onnx")
    ops = [n.op_type for n in onnx.load(path).graph.node]
    assert ops.count("SpaceToDepth") == 1 and ops.count("DepthToSpace") >= 2  # one fold in, the unfolds out
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    net.eval()
    # The padding inside is traced from the input's shape: one file takes sizes it was not exported at.
    for shape in ((1, 1, 32, 64), (2, 1, 96, 160), (1, 1, 224, 288)):
        x = _frame(shape, seed=2)
        x[..., ::7, ::3] = 0
        logit, pred = session.run(None, {"depth": x.numpy()})
        with torch.no_grad():
            want_logit, want_pred = net(x)
        np.testing.assert_allclose(logit, want_logit.numpy(), atol=1e-3)
        np.testing.assert_allclose(pred, want_pred.numpy(), atol=1e-3)


@pytest.mark.parametrize("passes", [None, 2])
def test_the_runtime_runs_the_fast_model_its_own_passes_unless_told(tmp_path, passes):
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.settings import RunSettings

    save_model(build(FAST_RECOVERY), FAST_RECOVERY, tmp_path / f"{FAST_RECOVERY}.safetensors", 0.0)
    s = RunSettings(model=FAST_RECOVERY, models=tmp_path, backend="torch", passes=passes)
    assert open_backend(s, detector=False).passes == (passes or 1)
    np.testing.assert_equal(open_backend(RunSettings(backend="torch"), detector=False).passes, 2)
