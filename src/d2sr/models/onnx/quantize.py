"""Optional int8 models for the edge: onnxruntime static quantization (QDQ, per-channel weights) of the
exported ONNX files, calibrated on generated frames (never the test seeds, never real recordings).
Torch-free. Its accuracy cost is measured by ``measure`` (``bench/quantize.py``)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from d2sr.atomic import atomic_file
from d2sr.contract import code_path
from d2sr.errors import InputError
from d2sr.models.onnx.half import float_weights
from d2sr.train.synth import VALIDATION_SEED as CALIBRATION_SEED

__all__ = ["CALIBRATION_SEED", "int8_path", "quantize"]


def int8_path(onnx: Path) -> Path:
    return onnx.with_name(onnx.stem + ".int8.onnx")


def _calibration(onnx: Path, frames: int) -> Iterator[dict[str, np.ndarray]]:
    """Generated validation frames as the runtime feeds them to ``onnx`` (a temporal model: with each one's
    last clean frame; a streaming one: with its code, from the fp32 files)."""
    from d2sr.runtime.backends import OnnxBackend
    from d2sr.train.synth import synth_sequence_frame

    detector = "score" in _outputs(onnx)
    net = OnnxBackend(onnx, None) if detector else OnnxBackend(None, onnx)
    for i in range(frames):
        s = synth_sequence_frame(CALIBRATION_SEED + i, bool(i % 2), previous=True)
        x, prev = (np.asarray(f, np.float32)[None] / np.float32(s.scale) for f in (s.frame, s.previous))
        yield net.detector_feeds(x, prev) if detector else net.recovery_feeds(x, prev)


def _outputs(onnx: Path) -> list[str]:
    import onnx as onnx_lib

    return [o.name for o in onnx_lib.load(str(onnx), load_external_data=False).graph.output]


def _with_float_weights(onnx: Path, tmp: Path) -> Path:
    """``onnx`` itself, or, where its weights are stored in float16 (``onnx_half``), a float32 copy in
    ``tmp``: the quantizer only quantizes weights it finds as initializers."""
    import onnx as onnx_lib

    proto = onnx_lib.load(str(onnx))
    if not any(i.data_type == onnx_lib.TensorProto.FLOAT16 for i in proto.graph.initializer):
        return onnx
    float_weights(proto.graph)
    onnx_lib.save(proto, str(tmp / onnx.name))
    return tmp / onnx.name


def quantize(onnx: Path, out: Path | None = None, frames: int = 16) -> Path:
    """Write ``<model>.int8.onnx`` next to ``onnx`` (or to ``out``) atomically."""
    try:
        from onnxruntime.quantization import CalibrationDataReader, QuantFormat, QuantType, quantize_static
    except ImportError:  # pragma: no cover - depends on the install
        raise InputError("int8 quantization needs onnxruntime: pip install 'd2sr[edge]'") from None
    if not onnx.is_file():
        raise InputError(f"{onnx}: no such model file (d2sr export writes it)")

    class Reader(CalibrationDataReader):
        def __init__(self) -> None:
            self.it = _calibration(onnx, frames)

        def get_next(self) -> dict[str, np.ndarray] | None:
            return next(self.it, None)

    target = out or int8_path(onnx)
    encoder = code_path(onnx)  # a streaming temporal UNet's encoder: kept in fp32 beside the int8 model
    with ExitStack() as stack:
        tmp = stack.enter_context(atomic_file(target))
        if encoder.is_file():
            shutil.copyfile(encoder, stack.enter_context(atomic_file(code_path(target))))
        quantize_static(
            str(_with_float_weights(onnx, Path(stack.enter_context(tempfile.TemporaryDirectory())))),
            str(tmp),
            Reader(),
            quant_format=QuantFormat.QDQ,
            per_channel=True,
            activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8,
        )
    return target
