"""ONNX export (one file per model, dynamic batch, height and width) with a parity check against torch.
Kept apart from inference: the edge runtime loads the files with onnxruntime and never imports torch."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from d2sr.atomic import atomic_file
from d2sr.contract import DETECTOR_NAMES, MASK_DETECTOR
from d2sr.errors import InputError
from d2sr.models.detector import Scored
from d2sr.models.store import load_model, mask_logit, threshold

__all__ = ["export", "parity"]

OPSET = 17


def _wrapped(model: nn.Module, name: str) -> tuple[nn.Module, list[str]]:
    if name in (*DETECTOR_NAMES, MASK_DETECTOR):
        return Scored(model).eval(), ["score"]
    return model, ["mask_logit", "pred_depth"]


def export(weights: Path, out: Path, check: bool = True) -> dict:
    """Export ``weights`` to ``out`` (.onnx); with ``check``, compare onnxruntime with torch on a random
    frame and refuse (InputError, nothing written) when they disagree. Returns the parity figures."""
    model, name = load_model(weights)
    net, outputs = _wrapped(model, name)
    h = int(getattr(model, "height", 0) or 480)
    x = torch.rand(2, int(getattr(model, "frames", 1)), h, 640) * 5
    axes = {"depth": {0: "batch", 2: "height", 3: "width"}} | {o: {0: "batch"} for o in outputs}
    with atomic_file(out) as tmp:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            torch.onnx.export(
                net,
                (x,),
                str(tmp),
                input_names=["depth"],
                output_names=outputs,
                dynamic_axes=axes,
                opset_version=OPSET,
                dynamo=False,
            )
        import onnx

        proto = onnx.load(str(tmp))
        meta = {
            "model": name,
            "stride": str(getattr(model, "stride", 1)),
            "height": str(getattr(model, "height", "") or ""),
            "frames": str(getattr(model, "frames", 1)),
            "mask_logit": repr(mask_logit(weights)),
            "threshold": repr(threshold(weights)),
        }
        for k, v in meta.items():
            entry = proto.metadata_props.add()
            entry.key, entry.value = k, v
        onnx.save(proto, str(tmp))
        result = parity(net, tmp, x) if check else {}
        if check and result["max_abs_diff"] > 1e-3:
            raise InputError(
                f"{out}: onnxruntime differs from torch by {result['max_abs_diff']:.2e}; not written"
            )
    return {"model": name, "file": str(out)} | result


def parity(net: nn.Module, onnx_file: Path, x: torch.Tensor) -> dict:
    """Largest absolute difference between torch and onnxruntime outputs on ``x`` (batch 2 and batch 1)."""
    import onnxruntime as ort

    sess = ort.InferenceSession(str(onnx_file), providers=["CPUExecutionProvider"])
    worst = 0.0
    for batch in (x, x[:1]):
        with torch.inference_mode():
            ref = net(batch)
        ref = ref if isinstance(ref, tuple) else (ref,)
        got = sess.run(None, {"depth": batch.numpy()})
        for r, g in zip(ref, got, strict=True):
            worst = max(worst, float(np.abs(r.numpy() - g).max()))
    return {"max_abs_diff": worst}
