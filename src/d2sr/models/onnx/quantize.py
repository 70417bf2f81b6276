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
from d2sr.contract.catalog import code_path, pair_path
from d2sr.errors import InputError
from d2sr.models.onnx.half import float_weights
from d2sr.sim.dataset import VALIDATION_SEED as CALIBRATION_SEED

__all__ = ["CALIBRATION_SEED", "TOLERANCE", "agreement", "int8_path", "quantize", "within_tolerance"]

# What int8 must keep of fp32 to stop being experimental, on real frames: detector verdicts differing on at
# most 5% of the frames, and the repair's RMSE at most 5% above fp32's.
TOLERANCE = {"verdicts_differing": 0.05, "rmse_ratio": 1.05}


def int8_path(onnx: Path) -> Path:
    return onnx.with_name(onnx.stem + ".int8.onnx")


def _calibration(onnx: Path, frames: int) -> Iterator[dict[str, np.ndarray]]:
    """Generated validation frames as the runtime feeds them to ``onnx`` (a temporal model: with each one's
    last clean frame; a streaming one: with its code, from the fp32 files)."""
    from d2sr.runtime.backends import OnnxBackend
    from d2sr.sim.dataset import synth_sequence_frame

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
        raise InputError("int8 quantization needs onnxruntime: pip install '.[edge]'") from None
    if not onnx.is_file():
        raise InputError(f"{onnx}: no such model file (d2sr export writes it)")

    class Reader(CalibrationDataReader):
        def __init__(self) -> None:
            self.it = _calibration(onnx, frames)

        def get_next(self) -> dict[str, np.ndarray] | None:
            return next(self.it, None)

    target = out or int8_path(onnx)
    with ExitStack() as stack:
        tmp = stack.enter_context(atomic_file(target))
        # A streaming model's second file (a temporal UNet's encoder, a temporal detector's pair scorer) is
        # kept in fp32 beside the int8 model.
        for second in (code_path, pair_path):
            if second(onnx).is_file():
                shutil.copyfile(second(onnx), stack.enter_context(atomic_file(second(target))))
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


def agreement(folder: Path, frames: list[tuple[np.ndarray, np.ndarray | None]], scale: float) -> dict:
    """The int8 detector and unet8 in ``folder`` (``quantize`` beside the fp32 ONNX files) against fp32 on
    ``frames`` (a uint16 frame, and the frame without interference or None): the share of detector
    verdicts that differ, the largest score difference, and each one's repair RMSE (cm) against the
    clean frame over the frames that have one."""
    from d2sr.contract.catalog import THRESHOLD
    from d2sr.contract.repair import repair_frame
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.settings import RunSettings

    nets = {
        "fp32": open_backend(RunSettings(model="unet8", backend="onnx", models=folder)),
        "int8": open_backend(RunSettings(model="unet8", backend="onnx", models=folder, int8=True)),
    }
    differ, diffs, se, n = 0, [0.0], {"fp32": 0.0, "int8": 0.0}, 0.0
    for frame, clean in frames:
        x = (frame.astype(np.float32) / np.float32(scale))[None]
        a, b = (float(net.scores(x)[0]) for net in nets.values())
        diffs.append(abs(a - b))
        differ += (a >= THRESHOLD) != (b >= THRESHOLD)
        if clean is None:
            continue
        ok = clean > 0
        n += float(ok.sum())
        for key, net in nets.items():
            pred, mask = net.recover(x)
            out, _ = repair_frame(frame, pred[0], mask[0], scale)
            se[key] += float((((out.astype(np.float64) - clean) / scale)[ok] ** 2).sum())
    rmse = {k: 100 * float(np.sqrt(v / max(n, 1.0))) for k, v in se.items()}
    return {
        "frames": len(frames),
        "verdicts_differing": differ / max(len(frames), 1),
        "score_diff_max": max(diffs),
        "rmse_cm": rmse,
        "rmse_ratio": rmse["int8"] / rmse["fp32"] if rmse["fp32"] > 0 else 1.0,
    }


def within_tolerance(figures: dict) -> bool:
    """Whether ``agreement``'s figures meet ``TOLERANCE``."""
    return bool(
        figures["verdicts_differing"] <= TOLERANCE["verdicts_differing"]
        and figures["rmse_ratio"] <= TOLERANCE["rmse_ratio"]
    )
