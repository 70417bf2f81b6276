"""The one-pass recovery model (unet8-fast): its folded layout, its fill, its export and its own passes."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from d2sr.contract.catalog import CATALOG, FAST_RECOVERY
from d2sr.models.onepass import OnePassUNet, _bilinear, block_fill, fold
from d2sr.models.onnx.export import export
from d2sr.models.registry import build, own_passes
from d2sr.models.store import save_model


def test_fold_is_pixel_shuffles_inverse_for_one_channel():
    x = torch.arange(2 * 1 * 16 * 24, dtype=torch.float32).reshape(2, 1, 16, 24)
    folded = fold(x, 8)
    assert folded.shape == (2, 64, 2, 3)
    assert torch.equal(F.pixel_shuffle(folded, 8), x)  # the heads unfold what the input folded
    assert folded[0, 8 * 2 + 5, 1, 2] == x[0, 0, 8 + 2, 16 + 5]  # channel i * 8 + j holds pixel (i, j)


def test_upsampling_on_the_block_grid_is_bilinear():
    coarse = torch.rand(1, 1, 6, 7)
    want = F.interpolate(coarse, scale_factor=8.0, mode="bilinear", align_corners=False)
    got = F.pixel_shuffle(F.conv2d(F.pad(coarse, (1, 1, 1, 1), mode="replicate"), _bilinear(8)), 8)
    assert torch.allclose(got, want, atol=1e-5)  # edges too: replicate padding is bilinear's clamp
    assert torch.allclose(_bilinear(8).sum(dim=(1, 2, 3)), torch.ones(64))


def test_the_fill_takes_the_trusted_returns_around_an_untrusted_block():
    depth = torch.full((1, 1, 64, 96), 2.0)
    depth[:, :, 24:40, 32:48] = 0.7  # a too-short patch, untrusted
    trust = torch.ones_like(depth)
    trust[:, :, 24:40, 32:48] = 0
    filled = F.pixel_shuffle(block_fill(fold(depth, 8), fold(trust, 8), 8, 2), 8)
    assert torch.allclose(filled[:, :, 24:40, 32:48], torch.tensor(2.0), atol=1e-5)
    # no trusted return anywhere: the frame's own mean, not zero or NaN
    empty = block_fill(fold(depth, 8), torch.zeros(1, 64, 8, 12), 8, 2)
    assert torch.isfinite(empty).all()


def test_one_pass_model_shapes_passes_and_export(tmp_path):
    net = build(FAST_RECOVERY)
    assert isinstance(net, OnePassUNet) and net.stride == 32
    assert own_passes(net) == CATALOG[FAST_RECOVERY].passes == 1
    assert own_passes(build("unet8")) == 2
    logit, pred = net.eval()(torch.rand(2, 1, 96, 128) * 4)
    assert logit.shape == pred.shape == (2, 1, 96, 128)
    weights = tmp_path / f"{FAST_RECOVERY}.safetensors"
    save_model(net, FAST_RECOVERY, weights, mask_logit=0.5)
    got = export(weights, tmp_path / f"{FAST_RECOVERY}.onnx")  # refuses when onnxruntime differs
    assert got["max_abs_diff"] < 1e-3
    import onnx

    ops = [n.op_type for n in onnx.load(str(tmp_path / f"{FAST_RECOVERY}.onnx")).graph.node]
    assert ops.count("SpaceToDepth") == 1 and ops.count("DepthToSpace") == 2  # one fold in, two unfolds out


@pytest.mark.parametrize("passes", [None, 2])
def test_the_runtime_runs_the_fast_model_its_own_passes_unless_told(tmp_path, passes):
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.settings import RunSettings

    save_model(build(FAST_RECOVERY), FAST_RECOVERY, tmp_path / f"{FAST_RECOVERY}.safetensors", 0.0)
    s = RunSettings(model=FAST_RECOVERY, models=tmp_path, backend="torch", passes=passes)
    assert open_backend(s, detector=False).passes == (passes or 1)
    np.testing.assert_equal(open_backend(RunSettings(backend="torch"), detector=False).passes, 2)
