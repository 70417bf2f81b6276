"""Benchmark: where the time of ``recover --repair all``'s worst case goes, per frame and in process. The same 60
real L515 frames as ``against.py`` (each corrupted by ``bench.outside``'s outside interference, so both passes
run on every frame), through the steps ``SensorLoop.process`` takes with the shipped unet8 on onnxruntime:
scale to metres, pass 1, its guard, the filled frame, pass 2, the final guard and write-back. Medians over
``--runs`` sweeps of the frames (the first sweep is a warm-up). Reading and writing PNGs are left out.

Run:  python -m lab.recover_parts --data ../shared/data \
          --json docs/results/bench_recover_parts.json
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import worst_case

from d2sr.atomic import write_result
from d2sr.contract.catalog import padded
from d2sr.contract.repair import guard, repair_frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings

PARTS = ("metres", "pass 1", "guard 1", "fill", "pass 2", "guard 2 + write-back")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--runs", type=int, default=3)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    scale = 4000.0
    frames = [frame for _, frame in worst_case(args.data)]
    net = open_backend(RunSettings(model="unet8", backend="onnx"), detector=False)
    cut = net.mask_logit
    ms: dict[str, list[float]] = {k: [] for k in (*PARTS, "total")}
    for run in range(args.runs + 1):
        for raw in frames:
            h, w = raw.shape
            t = [time.perf_counter()]
            metres = padded(raw.astype(np.float32)[None] / np.float32(scale))
            t.append(time.perf_counter())
            logit, pred = net.raw(metres, None)
            t.append(time.perf_counter())
            p, keep = guard(metres, pred, logit > cut)
            t.append(time.perf_counter())
            filled = np.where(keep, p, metres).astype(np.float32)
            t.append(time.perf_counter())
            logit2, pred2 = net.raw(filled, None)
            t.append(time.perf_counter())
            repair_frame(raw, pred2[0, :h, :w], (keep | (logit2 > cut))[0, :h, :w], scale)
            t.append(time.perf_counter())
            if run:  # the first sweep warms caches and onnxruntime's threads
                for k, a, b in zip(PARTS, t[:-1], t[1:], strict=True):
                    ms[k].append((b - a) * 1000)
                ms["total"].append((t[-1] - t[0]) * 1000)
    med = {k: round(statistics.median(v), 2) for k, v in ms.items()}
    result = {
        "benchmark": "recover --repair all worst case, per frame, in process (no PNG reading or writing)",
        "frames": "60 L515 dev1 frames, every one corrupted by bench.outside's outside_interference",
        "model": "unet8 (onnxruntime)",
        "runs": args.runs,
        "median_ms": med,
        "fps_in_process": round(1000 / med["total"], 1),
        "share_of_total": {k: round(med[k] / med["total"], 3) for k in PARTS},
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
