"""Benchmark: the int8 models (``d2sr export --int8``: onnxruntime static quantization, calibrated on
generated frames) against their fp32 originals on real L515 frames, every other one with the outside
interference (``bench.outside``): detector verdicts that differ, the score difference, and the repair's RMSE
against the frame before corruption, fp32 beside int8.

Run:  python -m lab.int8_real --data ../shared/data --json docs/results/int8_real.json
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import cv2
from bench.harness import check_output, output_args
from bench.outside.sets_a_i import outside_interference

from d2sr.atomic import write_result
from d2sr.contract.catalog import WEIGHTS, model_files
from d2sr.models.onnx.quantize import TOLERANCE, agreement, quantize, within_tolerance


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=60)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    files = sorted((args.data / "l515" / "dev1").glob("*.png"))[: args.frames]
    frames = []
    for i, f in enumerate(files):
        clean = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
        frames.append((outside_interference(clean, 4000.0, 7 + i), clean) if i % 2 else (clean, None))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in ("detector", "unet8"):
            for f in model_files(WEIGHTS, name):
                shutil.copyfile(f, folder / f.name)
            quantize(folder / f"{name}.onnx")
        got = agreement(folder, frames, 4000.0)
    result = {
        "data": f"{len(files)} real L515 dev1 frames, every other with outside interference (bench/outside)",
        "quantized": "the shipped detector and unet8 (16 generated calibration frames)",
        "agreement": got,
        "tolerance": TOLERANCE,
        "within_tolerance": within_tolerance(got),
    }
    print(write_result(result, args.json, models=["detector", "unet8"]))


if __name__ == "__main__":
    main()
