"""Models: every architecture through forward/backward at sizes its strides allow, size checks, the hard
composition (outside the mask bit-identical), weights round trip and corrupt files, ONNX parity."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from d2sr.contract.catalog import DETECTOR_NAMES, MASK_DETECTOR, RECOVERY_NAMES
from d2sr.errors import InputError
from d2sr.models import MODELS, build, check_input_size
from d2sr.models.store import load_model, save_model, warm_start
from d2sr.models.unet import push_pull


def _depth(n=2, h=96, w=128, seed=0) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    d = 0.5 + 4 * torch.rand(n, 1, h, w, generator=g)
    return d * (torch.rand(n, 1, h, w, generator=g) > 0.6)


@pytest.mark.parametrize("name", [n for n in MODELS if n not in ("paper-detector", MASK_DETECTOR)])
def test_forward_backward_at_allowed_sizes(name):
    torch.manual_seed(0)
    m = build(name)
    for h, w in ((96, 128), (64, 160)):
        x = torch.cat([_depth(2, h, w, seed=k) for k in range(getattr(m, "frames", 1))], dim=1)
        check_input_size(m, h, w)
        out = m(x)
        if name in DETECTOR_NAMES:
            assert out.shape == (2,)
            loss = out.sum()
        else:
            logit, pred = out
            assert logit.shape == pred.shape == (2, 1, h, w)
            loss = logit.mean() + pred.mean()
        loss.backward()
        assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in m.parameters())
        m.zero_grad()


def test_paper_detector_is_tied_to_480_rows():
    m = build("paper-detector")
    assert m(_depth(1, 480, 64)).shape == (1,)
    with pytest.raises(InputError, match="480 pixels high"):
        check_input_size(m, 240, 320)


@pytest.mark.parametrize("name", ["detector", "unet8", "paper-unet8"])
def test_size_checks_say_what_is_allowed(name):
    m = build(name)
    with pytest.raises(InputError, match=f"divisible by {m.stride}"):
        check_input_size(m, 100, 128)


def test_unknown_model_is_a_one_line_error():
    with pytest.raises(InputError, match="unknown model 'unet7'"):
        build("unet7")


def test_repair_leaves_pixels_outside_the_mask_bit_identical():
    torch.manual_seed(1)
    m = build("unet8").eval()
    x = _depth(1)
    with torch.inference_mode():
        out, mask = m.repair(x)
    assert mask.any() and (~mask).any()  # random weights: some of each
    assert torch.equal(out[~mask], x[~mask])
    assert (out[mask] >= 0).all()


@pytest.mark.parametrize("name", ["detector", "unet8"])
def test_weights_round_trip(tmp_path, name):
    torch.manual_seed(2)
    m = build(name).eval()
    save_model(m, name, tmp_path / "w.safetensors")
    back, got = load_model(tmp_path / "w.safetensors")
    assert got == name
    x = _depth(1)
    with torch.inference_mode():
        a, b = m(x), back(x)
    for u, v in zip(a if isinstance(a, tuple) else (a,), b if isinstance(b, tuple) else (b,), strict=True):
        assert torch.equal(u, v)


def test_corrupt_missing_and_mismatched_weights(tmp_path):
    with pytest.raises(InputError, match="no such weights file"):
        load_model(tmp_path / "none.safetensors")
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{not json at all")
    with pytest.raises(InputError, match="corrupt weights"):
        load_model(bad)
    good = tmp_path / "good.safetensors"
    save_model(build("unet8"), "unet8", good)
    good.write_bytes(good.read_bytes()[:-100])  # truncated
    with pytest.raises(InputError, match="corrupt weights"):
        load_model(good)
    wrong = tmp_path / "wrong.safetensors"
    save_model(build("unet16"), "unet8", wrong)  # says unet8, holds unet16 tensors
    with pytest.raises(InputError, match="do not fit unet8"):
        load_model(wrong)


@pytest.mark.parametrize("name", ["detector", "detector-temporal", "unet8", "unet8-temporal", MASK_DETECTOR])
def test_onnx_export_matches_torch_at_any_batch_and_size(tmp_path, name):
    import onnxruntime as ort

    from d2sr.contract.catalog import code_path, pair_path
    from d2sr.models.onnx.export import export, parity

    torch.manual_seed(3)
    w = tmp_path / f"{name}.safetensors"
    net = build(name).eval()
    frames = getattr(net, "frames", 1)
    detector = name in (*DETECTOR_NAMES, MASK_DETECTOR)
    save_model(net, name, w, mask_logit=None if detector else -1.5)
    res = export(w, tmp_path / f"{name}.onnx")
    assert res["max_abs_diff"] < 1e-3
    # A temporal UNet's encoder of the last clean frame is a file of its own, a temporal detector's score of
    # a frame with its previous one another; no other model has one.
    assert code_path(tmp_path / f"{name}.onnx").is_file() == (name == "unet8-temporal")
    assert pair_path(tmp_path / f"{name}.onnx").is_file() == (name == "detector-temporal")
    x = torch.cat([_depth(3, 64, 96, seed=5 + k) for k in range(frames)], dim=1)  # another batch and size
    model, _ = load_model(w)
    assert parity(model, detector, tmp_path / f"{name}.onnx", x)["max_abs_diff"] < 1e-3
    sess = ort.InferenceSession(str(tmp_path / f"{name}.onnx"), providers=["CPUExecutionProvider"])
    meta = sess.get_modelmeta().custom_metadata_map
    assert meta["model"] == name and int(meta["stride"]) == model.stride and int(meta["frames"]) == frames
    assert float(meta["mask_logit"]) == (0.0 if detector else -1.5)


@pytest.mark.parametrize("name", ["detector-temporal", "unet8-temporal"])
def test_streaming_form_is_the_model(name):
    # The UNet: the earlier frame's share of the first layers, computed apart and added back. The detector:
    # the frame alone and the pair, scored apart, the lower counting. The same functions.
    from d2sr.models.streaming import Pair, streaming

    torch.manual_seed(4)
    net = build(name).eval()
    stream = streaming(net)
    assert stream is not None and streaming(build("unet8")) is None
    x = torch.cat([_depth(2, 64, 96, seed=7), _depth(2, 64, 96, seed=8)], dim=1)
    with torch.inference_mode():
        ref = net(x)
        if name == "unet8-temporal":
            got = stream(x[:, :1], x[:, 1:], *stream.encode(x[:, 1:]))
        else:
            alone, pair = stream(x[:, :1]), Pair(net)(x[:, :1], x[:, 1:])
            ref, got = (torch.sigmoid(ref),), (torch.minimum(alone, pair),)
            self_pair = Pair(net)(x[:, :1], x[:, :1])  # alone: the frame as its own previous frame
            torch.testing.assert_close(alone, self_pair, atol=1e-5, rtol=1e-5)
    for r, g in zip(ref, got, strict=True):
        torch.testing.assert_close(r, g, atol=1e-4, rtol=1e-4)


def test_a_cut_scores_the_pair_only_where_the_frame_alone_reaches_it(tmp_path):
    # Below the cut alone is below it with the previous frame too: those frames keep their score alone (at
    # or above the exact one, below the cut) and the pair is never run for them; the others are exact. Both
    # backends, and the verdict at the cut is the exact one's.
    from d2sr.models.inference import TorchBackend
    from d2sr.models.onnx.export import export
    from d2sr.runtime.backends import OnnxBackend

    torch.manual_seed(6)
    w = tmp_path / "detector-temporal.safetensors"
    save_model(build("detector-temporal").eval(), "detector-temporal", w)
    export(w, tmp_path / "detector-temporal.onnx")
    cur, prev = _depth(8, 64, 96, seed=11)[:, 0].numpy(), _depth(8, 64, 96, seed=12)[:, 0].numpy()
    for net in (OnnxBackend(tmp_path / "detector-temporal.onnx", None), TorchBackend(w, None)):
        exact, alone = net.scores(cur, prev), net.scores(cur, None)
        assert (exact <= alone + 1e-6).all() and (exact < alone - 1e-4).any()  # the pair weighs in
        cut = float(np.median(alone))
        got = net.scores(cur, prev, cut)
        np.testing.assert_array_equal(got >= cut, exact >= cut)
        low = alone < cut
        assert 0 < low.sum() < len(low)
        np.testing.assert_allclose(got[low], alone[low], atol=1e-6)
        np.testing.assert_allclose(got[~low], exact[~low], atol=1e-6)
    net = OnnxBackend(tmp_path / "detector-temporal.onnx", None)

    class Never:
        def run(self, *args: object) -> None:
            raise AssertionError("the pair was scored")

    net.pair = Never()  # type: ignore[assignment]
    over = float(net.scores(cur, None).max()) + 1e-3
    assert (net.scores(cur, prev, over) < over).all()


def test_streaming_backend_follows_its_inputs_not_its_cache(tmp_path):
    # Codes are looked up by the earlier frame's value: a frame changed in place, or another frame, is
    # encoded again; a missing encoder file or a two-frame file of the old layout is a clear error.
    from d2sr.contract.catalog import code_path
    from d2sr.models.detector import Scored
    from d2sr.models.onnx.export import _onnx, export
    from d2sr.runtime.backends import OnnxBackend

    torch.manual_seed(5)
    for name in ("detector-temporal", "unet8-temporal"):
        save_model(build(name).eval(), name, tmp_path / f"{name}.safetensors")
        export(tmp_path / f"{name}.safetensors", tmp_path / f"{name}.onnx")
    model, _ = load_model(tmp_path / "unet8-temporal.safetensors")
    det, _ = load_model(tmp_path / "detector-temporal.safetensors")
    net = OnnxBackend(tmp_path / "detector-temporal.onnx", tmp_path / "unet8-temporal.onnx")
    cur, prev = _depth(1, 64, 96, seed=9)[:, 0].numpy(), _depth(1, 64, 96, seed=10)[:, 0].numpy()
    for change in (False, False, True):  # the second time from the cache; then changed in place
        if change:
            prev[:, 10:30] = 0.7
        with torch.inference_mode():
            want = model(torch.from_numpy(np.stack([cur, prev], 1)))
            score = torch.sigmoid(det(torch.from_numpy(np.stack([cur, prev], 1))))
        np.testing.assert_allclose(net.raw(cur, prev)[1], want[1][:, 0].numpy(), atol=1e-4)
        np.testing.assert_allclose(net.scores(cur, prev), score.numpy(), atol=1e-5)
    with torch.inference_mode():  # no earlier frame: the frame alone; no last clean frame: zeros
        alone = torch.sigmoid(det(torch.from_numpy(np.stack([cur, cur], 1))))
        blank = model(torch.from_numpy(np.stack([cur, np.zeros_like(cur)], 1)))
    np.testing.assert_allclose(net.scores(cur, None), alone.numpy(), atol=1e-5)
    np.testing.assert_allclose(net.raw(cur, None)[1], blank[1][:, 0].numpy(), atol=1e-4)
    code_path(tmp_path / "unet8-temporal.onnx").unlink()
    with pytest.raises(InputError, match=r"unet8-temporal\.code\.onnx: no such model file"):
        OnnxBackend(None, tmp_path / "unet8-temporal.onnx")
    old = tmp_path / "old.onnx"  # the earlier layout: the frame pair in one input
    _onnx(Scored(det).eval(), (torch.rand(1, 2, 64, 96),), old, ["depth"], ["score"], {"frames": "2"})
    with pytest.raises(InputError, match="exported by an earlier d2sr; export it again"):
        OnnxBackend(old, None)

    class OneCode(torch.nn.Module):  # the first streaming layout: both codes of a UNet in one input
        def forward(self, depth, previous, code):
            return depth + code[:, :1], previous

    d = torch.rand(1, 1, 64, 96)
    meta = {"frames": "2", "code_stride": "4"}
    _onnx(OneCode(), (d, d, torch.rand(1, 72, 64, 96)), old, ["depth", "previous", "code"], ["a", "b"], meta)
    with pytest.raises(InputError, match="exported by an earlier d2sr; export it again"):
        OnnxBackend(None, old)


def test_exported_unet_folds_pixels_with_space_to_depth(tmp_path):
    # pixel_unshuffle exports as a 6-D Transpose: 2.4 of unet8's 13.5 ms a 640x480 frame in onnxruntime.
    # The export is SpaceToDepth and a Gather of its channels: bit for bit pixel_unshuffle's values.
    import onnx
    import onnxruntime as ort
    import torch.nn.functional as F

    from d2sr.models.onnx.export import export
    from d2sr.models.unet import space_to_depth

    w = tmp_path / "unet8.safetensors"
    save_model(build("unet8").eval(), "unet8", w, mask_logit=0.0)
    export(w, tmp_path / "unet8.onnx")
    assert "Transpose" not in {n.op_type for n in onnx.load(str(tmp_path / "unet8.onnx")).graph.node}

    class Fold(torch.nn.Module):
        def __init__(self, s: int, c: int) -> None:
            super().__init__()
            self.s, self.c = s, c

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return space_to_depth(x, self.s, self.c)

    for s, c in ((2, 2), (4, 4)):
        x = torch.rand(2, c, 8 * s, 4 * s)
        path = tmp_path / f"fold{s}.onnx"
        torch.onnx.export(Fold(s, c), (x,), str(path), input_names=["x"], dynamo=False, opset_version=17)
        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        got = session.run(None, {"x": x.numpy()})[0]
        assert np.array_equal(got, F.pixel_unshuffle(x, s).numpy())


def test_every_recovery_model_has_the_paper_composition():
    # Recovery names cover ours and the paper's reference layouts; both share one class and the heads.
    assert {"unet8", "unet16", "unet32", "paper-unet8", "paper-unet16", "paper-unet32"} <= set(RECOVERY_NAMES)
    assert {"unet8-temporal", "unet8-direct"} <= set(RECOVERY_NAMES)
    # the torch registry and the torch-free contract
    assert tuple(MODELS) == (*DETECTOR_NAMES, *RECOVERY_NAMES, MASK_DETECTOR)
    assert build("paper-unet8").s2d == 1 and build("unet8").s2d == 4
    assert build("unet8").fill and not build("paper-unet8").fill and not build("unet8-direct").fill


def test_push_pull_keeps_trusted_pixels_and_fills_holes_from_their_surroundings():
    d = torch.full((1, 1, 64, 96), 2.0)
    d[..., :, 48:] = 4.0  # two walls
    w = torch.ones_like(d)
    w[..., 20:40, 10:30] = 0  # a hole in the near wall
    w[..., 20:40, 60:90] = 0  # and one in the far wall
    d_in = torch.where(w > 0, d, torch.zeros_like(d))
    out = push_pull(d_in, w)
    assert torch.equal(out[w > 0], d_in[w > 0])
    # Each hole takes its own wall's depth (coarse levels blend in a little of the other wall).
    torch.testing.assert_close(out[..., 25:35, 15:25], torch.full((1, 1, 10, 10), 2.0), atol=0.15, rtol=0)
    torch.testing.assert_close(out[..., 25:35, 70:80], torch.full((1, 1, 10, 10), 4.0), atol=0.15, rtol=0)
    nothing = push_pull(d_in, torch.zeros_like(w))  # no trusted pixel at all: zeros, not NaN
    assert torch.isfinite(nothing).all()


def test_temporal_model_started_from_unet8_equals_it_until_it_has_a_clean_frame(tmp_path):
    torch.manual_seed(4)
    base = build("unet8").eval()
    save_model(base, "unet8", tmp_path / "u.safetensors")
    temporal = build("unet8-temporal").eval()
    counts = warm_start(temporal, tmp_path / "u.safetensors")
    assert counts["grown"] == 4 and counts["untouched"] == 0  # stem and head convs take the new channels
    x = _depth(1)
    with torch.inference_mode():
        a = base(x)
        b = temporal(torch.cat([x, torch.zeros_like(x)], dim=1))
    for u, v in zip(a, b, strict=True):
        torch.testing.assert_close(u, v)
    with pytest.raises(InputError, match="no such weights"):
        warm_start(temporal, tmp_path / "none.safetensors")
    save_model(build("detector"), "detector", tmp_path / "d.safetensors")
    with pytest.raises(InputError, match="no tensor fits"):
        warm_start(temporal, tmp_path / "d.safetensors")


def test_saved_weights_get_the_usual_permissions(tmp_path):
    import os

    import torch

    from d2sr.models.store import save_model

    old = os.umask(0o022)
    try:
        save_model(torch.nn.Linear(2, 2), "detector", tmp_path / "w.safetensors")
    finally:
        os.umask(old)
    assert (tmp_path / "w.safetensors").stat().st_mode & 0o777 == 0o644


def test_temporal_detector_flags_only_what_looks_interfered_alone_and_against_the_frame_before():
    torch.manual_seed(0)
    det = build("detector-temporal")
    frame, before = torch.rand(3, 1, 64, 96) * 4, torch.rand(3, 1, 64, 96) * 4
    pair = torch.cat([frame, before], dim=1)
    with torch.no_grad():
        trained_on = det.train()(pair)  # training scores the pair as it is
        det.eval()
        alone = det.logit(torch.cat([frame, frame], dim=1))
        assert torch.allclose(det(pair), torch.minimum(trained_on, alone))
        # No previous frame: the frame stands in for it, and the score is the frame's alone.
        assert torch.allclose(det(torch.cat([frame, frame], dim=1)), alone)


def test_mask_detector_scores_the_share_of_returns_its_model_would_repair():
    from d2sr.models.detector import REF_SHARE, MaskDetector

    class Fixed(torch.nn.Module):  # mask logits +10 on the first k pixels of each row, -10 elsewhere
        frames, stride = 1, 1

        def __init__(self, k: int) -> None:
            super().__init__()
            self.k = k

        def forward(self, depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            logit = torch.full_like(depth, -10.0)
            logit[..., : self.k] = 10.0
            return logit, depth

    depth = torch.ones(2, 1, 10, 100)
    depth[1, :, :, 50:] = 0  # half the second frame returns nothing: the share is of its returns
    for k, share in ((0, (0.0, 0.0)), (1, (0.01, 0.02)), (25, (0.25, 0.5))):
        got = torch.sigmoid(MaskDetector(Fixed(k), cut=2.0)(depth))
        want = torch.tensor([(s + 1e-6) / (s + 1e-6 + REF_SHARE) for s in share])
        torch.testing.assert_close(got, want, atol=1e-4, rtol=0)
    # the cut decides which pixels count: well above every logit, none do
    assert torch.sigmoid(MaskDetector(Fixed(25), cut=13.0)(depth)).max() < 0.001


def test_a_narrow_unet_widens_to_the_same_function(tmp_path):
    # unet16 started as unet8 (models.widen): the same outputs before the noise that parts the copies,
    # and warm_start does it for a narrower UNet of the same layout (never for another layout).
    from d2sr.models.widen import can_widen, widen

    torch.manual_seed(6)
    narrow, wide = build("unet8").eval(), build("unet16").eval()
    x = _depth(2, 64, 96, seed=11)
    widen(narrow, wide, noise=0.0)
    with torch.inference_mode():
        for a, b in zip(narrow(x), wide(x), strict=True):
            torch.testing.assert_close(a, b, atol=1e-4, rtol=1e-4)
    save_model(narrow, "unet8", tmp_path / "unet8.safetensors")
    again = build("unet16").eval()
    assert warm_start(again, tmp_path / "unet8.safetensors")["widened"] == len(again.state_dict())
    with torch.inference_mode():  # the noise: near the same function, the copies no longer equal
        a, b = narrow(x)[1], again(x)[1]
        assert 0 < float((a - b).abs().max()) < 0.1
    first = again.down[0][0].weight
    assert not torch.equal(first[:8], first[8:])
    assert not can_widen(build("unet8"), build("unet8-temporal")) and not can_widen(wide, narrow)
    with pytest.raises(ValueError, match="one layout"):
        widen(build("unet8"), build("unet8-temporal"))


def test_large_models_are_stored_in_float16_and_exported_with_the_same_function(tmp_path, monkeypatch):
    # A model over HALF_ABOVE parameters (unet32) keeps float16 in its files and computes in float32; its
    # ONNX weights are float16 read through folded Casts: the same outputs as float32 weights of those
    # values. Small models are stored as they are.
    import onnx
    import onnxruntime as ort
    from safetensors.torch import load_file

    import d2sr.models.store as store
    from d2sr.models.onnx.export import export

    torch.manual_seed(6)
    net = build("unet8").eval()
    save_model(net, "unet8", tmp_path / "small.safetensors")
    assert all(t.dtype == torch.float32 for t in load_file(str(tmp_path / "small.safetensors")).values())
    monkeypatch.setattr(store, "HALF_ABOVE", 1000)  # unet8 counts as large
    w = tmp_path / "unet8.safetensors"
    save_model(net, "unet8", w, mask_logit=0.5)
    assert all(t.dtype == torch.float16 for t in load_file(str(w)).values() if t.is_floating_point())
    back, _ = load_model(w)
    for (k, a), b in zip(net.state_dict().items(), back.state_dict().values(), strict=True):
        assert b.dtype == torch.float32 and torch.equal(b, a.half().float()), k
    export(w, tmp_path / "half.onnx")
    graph = onnx.load(str(tmp_path / "half.onnx")).graph
    halves = [i for i in graph.initializer if i.data_type == onnx.TensorProto.FLOAT16]
    assert len(halves) >= 17 and sum(n.op_type == "Cast" for n in graph.node) >= len(halves)
    monkeypatch.setattr(store, "HALF_ABOVE", 10**9)  # the same weights, exported in float32
    export(w, tmp_path / "full.onnx")
    assert (tmp_path / "half.onnx").stat().st_size < 0.6 * (tmp_path / "full.onnx").stat().st_size
    x = {"depth": _depth(1, 64, 96, seed=11).numpy()}
    got, want = (
        ort.InferenceSession(str(tmp_path / f), providers=["CPUExecutionProvider"]).run(None, x)
        for f in ("half.onnx", "full.onnx")
    )
    for g, r in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, r)
    # What the int8 quantizer sees (it quantizes only weights it finds as initializers): float32 again.
    from d2sr.models.onnx.half import float_weights

    float_weights(graph)
    full = {i.name: i for i in onnx.load(str(tmp_path / "full.onnx")).graph.initializer}
    assert {i.name for i in graph.initializer} == set(full)
    assert not any(n.op_type == "Cast" and n.input[0].endswith(".f16") for n in graph.node)
    for i in graph.initializer:
        np.testing.assert_array_equal(onnx.numpy_helper.to_array(i), onnx.numpy_helper.to_array(full[i.name]))


def test_one_catalogue_of_model_names():
    from d2sr.contract.catalog import CATALOG, WEIGHTS

    assert set(MODELS) == set(CATALOG)  # the registry builds exactly the catalogue's names
    for name, entry in CATALOG.items():
        assert (WEIGHTS / f"{name}.onnx").is_file() == entry.shipped, name
        assert isinstance(build(name), torch.nn.Module) and entry.kind in ("detector", "recovery")
