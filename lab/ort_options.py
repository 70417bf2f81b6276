"""Benchmark (issue 78): onnxruntime's session options on one recovery pass at 640x480, one thread, in one
process: thread spinning, the graph optimization level and the NCHWc layout (``NchwcTransformer``), for
unet8 and unet8-fast (random weights: speed does not depend on them). Settings alternate run by run so a
noisy machine slows all alike; medians of ``--repeats``.

Run:  python -m lab.ort_options --json docs/results/ort_options.json
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort
import torch
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.contract.catalog import FAST_RECOVERY, padded
from d2sr.models.onnx.export import _onnx
from d2sr.models.registry import build

LEVELS = {
    "basic": ort.GraphOptimizationLevel.ORT_ENABLE_BASIC,
    "extended": ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED,
    "all": ort.GraphOptimizationLevel.ORT_ENABLE_ALL,
}
# name: (spinning, level, NCHWc). The first is how d2sr's OnnxBackend opens a session.
OPTIONS: dict[str, tuple[bool, str, bool]] = {
    "as d2sr runs it (no spinning, all, NCHWc)": (False, "all", True),
    "spinning": (True, "all", True),
    "no NCHWc": (False, "all", False),
    "extended": (False, "extended", True),
    "basic": (False, "basic", True),
}


def _session(path: Path, spin: bool, level: str, nchwc: bool) -> ort.InferenceSession:
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    opts.graph_optimization_level = LEVELS[level]
    opts.add_session_config_entry("session.intra_op.allow_spinning", "1" if spin else "0")
    off = [] if nchwc else ["NchwcTransformer"]
    return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"], disabled_optimizers=off)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    torch.manual_seed(0)
    frame = np.random.default_rng(0).uniform(0, 5, (1, 480, 640)).astype(np.float32)
    frame[frame < 0.5] = 0
    x = padded(frame)[:, None]
    models = ("unet8", FAST_RECOVERY)
    with tempfile.TemporaryDirectory() as t:
        sessions = {}
        for m in models:
            path = Path(t) / f"{m}.onnx"
            _onnx(build(m).eval(), (torch.from_numpy(x),), path, ["depth"], ["mask_logit", "pred_depth"], {})
            for name, opt in OPTIONS.items():
                sessions[(m, name)] = _session(path, *opt)
        for s in sessions.values():
            for _ in range(3):
                s.run(None, {"depth": x})
        times: dict[tuple[str, str], list[float]] = {k: [] for k in sessions}
        for _ in range(args.repeats):
            for key, s in sessions.items():
                t0 = time.perf_counter()
                s.run(None, {"depth": x})
                times[key].append(1000 * (time.perf_counter() - t0))
    ms = {m: {n: round(statistics.median(times[(m, n)]), 2) for n in OPTIONS} for m in models}
    first = next(iter(OPTIONS))
    result = {
        "benchmark": "issue 78: onnxruntime session options, one recovery pass at 640x480 on one thread",
        "repeats": args.repeats,
        "ms_one_thread": ms,
        "ratio_to_as_run": {m: {n: round(v / ms[m][first], 3) for n, v in ms[m].items()} for m in models},
        "fast_to_unet8_as_run": round(ms[FAST_RECOVERY][first] / ms["unet8"][first], 3),
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
