"""Optional int8 models for the edge: onnxruntime static quantization (QDQ, per-channel weights) of the
exported ONNX files, calibrated on generated frames (never the test seeds, never real recordings).
Torch-free. Its accuracy cost is measured by ``measure`` (``bench/quantize.py``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from d2sr.atomic import atomic_file
from d2sr.errors import InputError
from d2sr.train.synth import VALIDATION_SEED as CALIBRATION_SEED

__all__ = ["CALIBRATION_SEED", "int8_path", "quantize"]


def int8_path(onnx: Path) -> Path:
    return onnx.with_name(onnx.stem + ".int8.onnx")


def _calibration(frames: int, channels: int) -> Iterator[dict[str, np.ndarray]]:
    """Generated validation frames; a temporal model (2 channels) also gets each one's last clean frame."""
    from d2sr.train.synth import synth_sequence_frame

    for i in range(frames):
        s = synth_sequence_frame(CALIBRATION_SEED + i, bool(i % 2), previous=channels > 1)
        x = np.stack([s.frame] + ([s.previous] if s.previous is not None else [])).astype(np.float32)
        yield {"depth": (x / np.float32(s.scale))[None]}


def quantize(onnx: Path, out: Path | None = None, frames: int = 16) -> Path:
    """Write ``<model>.int8.onnx`` next to ``onnx`` (or to ``out``) atomically."""
    try:
        from onnxruntime.quantization import CalibrationDataReader, QuantFormat, QuantType, quantize_static
    except ImportError:  # pragma: no cover - depends on the install
        raise InputError("int8 quantization needs onnxruntime: pip install 'd2sr[edge]'") from None
    if not onnx.is_file():
        raise InputError(f"{onnx}: no such model file (d2sr export writes it)")

    import onnx as onnx_lib

    meta = {p.key: p.value for p in onnx_lib.load(str(onnx), load_external_data=False).metadata_props}
    channels = int(meta.get("frames", 1))

    class Reader(CalibrationDataReader):
        def __init__(self) -> None:
            self.it = _calibration(frames, channels)

        def get_next(self) -> dict[str, np.ndarray] | None:
            return next(self.it, None)

    target = out or int8_path(onnx)
    with atomic_file(target) as tmp:
        quantize_static(
            str(onnx),
            str(tmp),
            Reader(),
            quant_format=QuantFormat.QDQ,
            per_channel=True,
            activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8,
        )
    return target
