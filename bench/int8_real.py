"""Benchmark: the int8 models (``d2sr export --int8``: onnxruntime static quantization, calibrated on
generated frames) against their fp32 originals on real L515 frames, every other one with the outside
interference (``held_out``): detector verdicts that differ, the score difference, and the repair's RMSE
against the frame before corruption, fp32 beside int8.

Run:  .venv/bin/python bench/int8_real.py --data ../shared/data --json docs/results/int8_real.json
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
from pathlib import Path

import cv2
import numpy as np

from d2sr.bench import check_output, output_args, write_result
from d2sr.contract import THRESHOLD, WEIGHTS, repair_frame
from d2sr.models.onnx.quantize import quantize
from d2sr.runtime.backends import open_backend
from held_out import outside_interference


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=60)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    files = sorted((args.data / "l515" / "dev1").glob("*.png"))[: args.frames]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in ("detector", "unet8"):
            for ext in (".onnx", ".safetensors"):
                shutil.copyfile(WEIGHTS / f"{name}{ext}", folder / f"{name}{ext}")
            quantize(folder / f"{name}.onnx")
        fp32 = open_backend("unet8", "onnx", folder)
        int8 = open_backend("unet8", "onnx", folder, int8=True)
        flips, diffs = 0, []
        se = {"fp32": 0.0, "int8": 0.0, "input": 0.0}
        n = 0.0
        for i, f in enumerate(files):
            clean = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
            x = outside_interference(clean, 4000.0, 7 + i) if i % 2 else clean
            m = (x.astype(np.float32) / 4000)[None]
            a, b = float(fp32.scores(m)[0]), float(int8.scores(m)[0])
            diffs.append(abs(a - b))
            flips += (a >= THRESHOLD) != (b >= THRESHOLD)
            if i % 2 == 0:
                continue
            ok = clean > 0
            n += float(ok.sum())
            se["input"] += float((((x.astype(np.float64) - clean) / 4000)[ok] ** 2).sum())
            for key, net in (("fp32", fp32), ("int8", int8)):
                pred, mask = net.recover(m)
                out, _ = repair_frame(x, pred[0], mask[0], 4000.0)
                se[key] += float((((out.astype(np.float64) - clean) / 4000)[ok] ** 2).sum())
    result = {
        "data": f"{len(files)} real L515 dev1 frames, every other with outside interference (held_out.py)",
        "quantized": "the shipped detector and unet8 (16 generated calibration frames)",
        "detector_verdicts_differing": f"{flips} of {len(files)}",
        "detector_score_diff_median": round(statistics.median(diffs), 4),
        "detector_score_diff_max": round(max(diffs), 4),
        "repair_rmse_cm": {k: round(100 * float(np.sqrt(v / n)), 2) for k, v in se.items()},
        "repaired_frames": len(files) // 2,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
