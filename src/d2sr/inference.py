"""Open the detector and a recovery model on the best backend at hand: onnxruntime (``d2sr.runtime``,
no torch) when it is installed and the ONNX files exist, torch (``d2sr.models``) otherwise. It sits above
both so that neither imports the other."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from d2sr.contract import (
    AUTO_RECOVERY,
    AUTO_TEMPORAL_LOGIT,
    DEFAULT_RECOVERY,
    DETECTOR,
    REPAIR_PASSES,
    SHIPPED_RECOVERY,
    TEMPORAL_RECOVERY,
    WEIGHTS,
)
from d2sr.errors import InputError
from d2sr.runtime.backends import Backend, Gated, OnnxBackend

__all__ = ["BACKENDS", "open_backend"]

BACKENDS = ("auto", "onnx", "torch")


def _has(weights: Path, name: str) -> bool:
    """The folder holds model ``name`` (ONNX or safetensors)."""
    return any((weights / f"{name}{e}").is_file() for e in (".onnx", ".safetensors"))


def open_backend(
    model: str | None = DEFAULT_RECOVERY,
    backend: str = "auto",
    weights: Path = WEIGHTS,
    detector: str | None = DETECTOR,
    threads: int | None = None,
    int8: bool = False,
    mask_logit: float | None = None,
    passes: int = REPAIR_PASSES,
) -> Backend:
    """The shipped (or given folder's) detector and recovery model ``model`` (None: the detector only;
    ``detector=None``: the recovery model only). ``mask_logit`` overrides the recovery model's own mask
    threshold (a logit); ``passes``: runs of the recovery model per frame (``contract.recover_passes``).
    ``model="auto"``: ``unet8-temporal`` where the last clean frame lines up, at auto's own mask logit
    (``AUTO_TEMPORAL_LOGIT``, unless ``mask_logit`` is given), ``unet8`` elsewhere
    (``runtime.backends.Gated``); ``unet8`` alone in a folder without ``unet8-temporal`` (d2sr adapt's)."""
    if model == AUTO_RECOVERY:
        single = open_backend(DEFAULT_RECOVERY, backend, weights, detector, threads, int8, mask_logit, passes)
        if not _has(weights, TEMPORAL_RECOVERY):
            return single
        own = AUTO_TEMPORAL_LOGIT if mask_logit is None else mask_logit
        temporal = open_backend(TEMPORAL_RECOVERY, backend, weights, None, threads, int8, own, passes)
        return Gated(single, temporal)
    if backend not in BACKENDS:
        raise InputError(f"unknown backend {backend!r}; choose {', '.join(BACKENDS)}")
    if mask_logit is not None and not np.isfinite(mask_logit):
        raise InputError(f"--mask-logit must be a finite number, got {mask_logit}")
    if not weights.is_dir():
        raise InputError(f"{weights}: no such weights folder")
    names = ([detector] if detector else []) + ([model] if model else [])
    if not names:
        raise InputError("open_backend needs a detector, a recovery model or both")
    for name in names:
        if not _has(weights, name):
            hint = f" (shipped: {', '.join(SHIPPED_RECOVERY)}; `make weights` trains the others)"
            raise InputError(f"no such model {name} in {weights}" + (hint if weights == WEIGHTS else ""))
    ext = ".int8.onnx" if int8 else ".onnx"  # int8: d2sr export --int8
    det_onnx = weights / f"{detector}{ext}" if detector else None
    rec_onnx = weights / f"{model}{ext}" if model else None
    onnx_files = [f for f in (det_onnx, rec_onnx) if f is not None]
    if int8 and backend == "torch":
        raise InputError("int8 models run on onnxruntime (--backend onnx)")
    if int8:
        backend = "onnx"
    if backend == "auto":
        has_ort = importlib.util.find_spec("onnxruntime") is not None
        backend = "onnx" if has_ort and all(f.is_file() for f in onnx_files) else "torch"
    if backend == "onnx":
        return OnnxBackend(det_onnx, rec_onnx, threads, mask_logit, passes)
    if importlib.util.find_spec("torch") is None:
        raise InputError(f"no ONNX models in {weights} and torch is not installed")
    from d2sr.models.inference import TorchBackend

    rec = weights / f"{model}.safetensors" if model else None
    det = weights / f"{detector}.safetensors" if detector else None
    return TorchBackend(det, rec, mask_logit, passes)
