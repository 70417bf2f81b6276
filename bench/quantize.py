"""int8 against fp32 (onnxruntime): speed at 640x480 and the accuracy cost on held-out generated frames
(detector precision/recall; UNet8 RMSE, mask F1, clean pixels changed). Quantizes the shipped ONNX files
into a temporary folder unless --weights holds *.int8.onnx already.

Run:  .venv/bin/python bench/quantize.py --json docs/results/quantize.json
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from d2sr.atomic import write_result
from d2sr.contract.catalog import WEIGHTS, model_files
from d2sr.contract.repair import repair_frame
from d2sr.eval.models import detector_metrics, generated_set, recovery_metrics
from d2sr.models.onnx.quantize import int8_path, quantize
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings
from harness import check_output, output_args


def ms(fn: object, repeats: int = 20) -> float:
    fn()  # type: ignore[operator]
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()  # type: ignore[operator]
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200, help="generated test frames for the detector")
    ap.add_argument("--limit", type=int, default=40, help="interfered frames for recovery")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    ts = generated_set(Path("out/data"))
    ts.frames, ts.clean, ts.hard = ts.frames[: args.frames], ts.clean[: args.frames], ts.hard[: args.frames]
    ts.__dict__.pop("labels", None)
    result: dict = {"benchmark": "int8 vs fp32, onnxruntime, 640x480, batch 1", "per_model": {}}
    with tempfile.TemporaryDirectory() as tmp:
        wdir = Path(tmp)
        for name in ("detector", "unet8"):
            for f in model_files(WEIGHTS, name):
                shutil.copy(f, wdir / f.name)
            quantize(wdir / f"{name}.onnx")
            result["per_model"][name] = {
                "fp32_mb": round((wdir / f"{name}.onnx").stat().st_size / 2**20, 3),
                "int8_mb": round(int8_path(wdir / f"{name}.onnx").stat().st_size / 2**20, 3),
            }
        x = ts.metres(1)[None]
        for int8 in (False, True):
            key = "int8" if int8 else "fp32"
            net = open_backend(RunSettings(model="unet8", backend="onnx", models=wdir, int8=int8))
            result["per_model"]["detector"][f"{key}_ms"] = round(ms(lambda net=net: net.scores(x)), 2)
            result["per_model"]["unet8"][f"{key}_ms"] = round(ms(lambda net=net: net.recover(x)), 2)
            scores = np.array([float(net.scores(ts.metres(i)[None])[0]) for i in range(len(ts.frames))])
            det = detector_metrics(scores, ts)
            result["per_model"]["detector"][key] = {
                k: round(det[k], 4) for k in ("precision", "recall", "f1")
            }

            def repair(x: np.ndarray, prev: np.ndarray | None, scale: float, net=net):  # noqa: ANN001, ANN202
                pred, mask = net.recover(x[None])
                units, kept = repair_frame(np.rint(x * scale).astype(np.uint16), pred[0], mask[0], scale)
                return units.astype(np.float32) / np.float32(scale), kept

            rows, _ = recovery_metrics(ts, {"unet8": repair}, None, args.limit)
            r = rows["unet8"]
            result["per_model"]["unet8"][key] = {
                k: r[k] for k in ("rmse_cm", "rmse_vs_identity", "mask_f1", "clean_changed")
            }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
