"""ONNX export (dynamic batch, height and width) with a parity check against torch. Kept apart from
inference: the edge runtime loads the files with onnxruntime and never imports torch.

One file per model, except that two-frame models are exported in their streaming form
(``d2sr.models.streaming``), each with a second file beside it (``second_path``): the temporal detector's
scores a frame with its previous frame (``contract.pair_path``), the temporal UNet's encodes the last
clean frame (``contract.code_path``)."""

from __future__ import annotations

import warnings
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import torch
from torch import nn

from d2sr.atomic import atomic_file
from d2sr.contract.catalog import (
    ALONE,
    DETECTOR_NAMES,
    MASK_DETECTOR,
    PAIR_INPUTS,
    STREAM_CODES,
    STREAM_INPUTS,
)
from d2sr.errors import InputError
from d2sr.models.detector import Scored
from d2sr.models.onnx.half import half_weights
from d2sr.models.store import load_model, mask_logit, stored_in_half, threshold
from d2sr.models.streaming import Encoder, Pair, StreamingDetector, StreamingUNet, streaming

__all__ = ["export", "parity"]

OPSET = 17


def _onnx(net: nn.Module, args: tuple, path: Path, inputs: list[str], outputs: list[str], meta: dict) -> None:
    """Write ``net`` to ``path`` with every axis but the channels dynamic, and ``meta`` as its metadata."""
    import onnx

    axes = {k: {0: "batch", 2: f"{k}_height", 3: f"{k}_width"} for k in inputs} | {
        o: {0: "batch"} for o in outputs
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            net,
            args,
            str(path),
            input_names=inputs,
            output_names=outputs,
            dynamic_axes=axes,
            opset_version=OPSET,
            dynamo=False,
        )
    proto = onnx.load(str(path))
    for k, v in meta.items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = k, v
    if stored_in_half(net):
        half_weights(proto.graph)
    onnx.save(proto, str(path))


def export(weights: Path, out: Path, check: bool = True) -> dict:
    """Export ``weights`` to ``out`` (.onnx; a temporal detector also to ``pair_path(out)``, a temporal UNet
    to ``code_path(out)``); with ``check``,
    compare onnxruntime with torch on random frames and refuse (InputError, nothing written) when they
    disagree. Returns the parity figures."""
    model, name = load_model(weights)
    detector = name in (*DETECTOR_NAMES, MASK_DETECTOR)
    h = int(getattr(model, "height", 0) or 480)
    x = torch.rand(2, int(getattr(model, "frames", 1)), h, 640) * 5
    stream = streaming(model)
    meta = {
        "model": name,
        "stride": str(getattr(model, "stride", 1)),
        "height": str(getattr(model, "height", "") or ""),
        "frames": str(getattr(model, "frames", 1)),
        "mask_logit": repr(mask_logit(weights)),
        "threshold": repr(threshold(weights)),
    }
    if isinstance(stream, StreamingUNet):
        meta["code_stride"] = str(stream.code_stride)
    with ExitStack() as stack:
        tmp = stack.enter_context(atomic_file(out))
        second = None
        if isinstance(stream, StreamingDetector):
            second = stack.enter_context(atomic_file(stream.second_path(out)))
            _onnx(stream, (x[:, :1],), tmp, list(STREAM_INPUTS["detector"]), ["score"], meta | ALONE)
            _onnx(Pair(stream.det), (x[:, :1], x[:, 1:]), second, list(PAIR_INPUTS), ["score"], meta)
        elif isinstance(stream, StreamingUNet):
            second = stack.enter_context(atomic_file(stream.second_path(out)))
            _onnx(Encoder(stream), (x[:, 1:],), second, ["previous"], list(STREAM_CODES), meta)
            with torch.inference_mode():
                args = (x[:, :1], x[:, 1:], *stream.encode(x[:, 1:]))
            _onnx(stream, args, tmp, list(STREAM_INPUTS["recovery"]), ["mask_logit", "pred_depth"], meta)
        else:
            net, outputs = (
                (Scored(model).eval(), ["score"]) if detector else (model, ["mask_logit", "pred_depth"])
            )
            _onnx(net, (x,), tmp, ["depth"], outputs, meta)
        result = parity(model, detector, tmp, x, second) if check else {}
        if check and result["max_abs_diff"] > 1e-3:
            raise InputError(
                f"{out}: onnxruntime differs from torch by {result['max_abs_diff']:.2e}; not written"
            )
    return {"model": name, "file": str(out)} | result


def parity(
    model: nn.Module, detector: bool, onnx_file: Path, x: torch.Tensor, second: Path | None = None
) -> dict:
    """Largest absolute difference between the torch model and the exported file(s) as the runtime runs
    them (``OnnxBackend``), on ``x`` (metres, (N, frames, H, W)) at batch 2 and batch 1. ``second``: a
    streaming model's second file, where it is not beside ``onnx_file`` under its usual name."""
    from d2sr.runtime.backends import OnnxBackend

    backend = (
        OnnxBackend(onnx_file, None, pair=second)
        if detector
        else OnnxBackend(None, onnx_file, encoder=second)
    )
    worst = 0.0
    for batch in (x, x[:1]):
        metres = batch[:, 0].numpy()
        previous = batch[:, 1].numpy() if batch.shape[1] > 1 else None
        with torch.inference_mode():
            ref = torch.sigmoid(model(batch)) if detector else model(batch)
        ref = ref if isinstance(ref, tuple) else (ref,)
        if detector:
            got: tuple[np.ndarray, ...] = (backend.scores(metres, previous),)
        else:
            logit, pred = backend.raw(metres, previous)
            got = (logit[:, None], pred[:, None])
        for r, g in zip(ref, got, strict=True):
            worst = max(worst, float(np.abs(r.numpy() - g).max()))
    return {"max_abs_diff": worst}
