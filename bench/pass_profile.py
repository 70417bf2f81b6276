"""Benchmark (issue 44): where one model pass's milliseconds go at 640x480, on one onnxruntime thread (how
``d2sr recover`` runs each of its two frames at once on 2 cores): per operator type, and per convolution
with the rate it reaches (GFLOP/s), for the shipped fp32 unet8 and detector, the int8 unet8 the runtime
offers (``d2sr.models.onnx.quantize``: QDQ, per-channel), one in onnxruntime's other format (QOperator) and
one with only its convolutions quantized. The int8 files are written to a temporary folder and calibrated
as ``d2sr export --int8`` calibrates (their accuracy on real frames: ``lab/int8_real.py``). Medians over
``--runs`` passes after 3 warm-up passes; the profile is onnxruntime's own, over the same passes.

Run:  .venv/bin/python bench/pass_profile.py --json docs/results/pass_profile.json
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
import onnxruntime as ort

from d2sr.atomic import write_result
from d2sr.contract.catalog import WEIGHTS
from d2sr.models.onnx.quantize import quantize
from harness import check_output, output_args

SIZE = (480, 640)


def _feeds(session: ort.InferenceSession) -> dict[str, np.ndarray]:
    """Depths of 0.3-4 m for every input (a temporal model's second one too), at ``SIZE``."""
    rng = np.random.default_rng(0)
    feeds = {}
    for i in session.get_inputs():
        shape = [1, *[d if isinstance(d, int) else 1 for d in i.shape[1:-2]], *SIZE]
        feeds[i.name] = rng.uniform(0.3, 4.0, shape).astype(np.float32)
    return feeds


def profile(path: Path, runs: int, prefix: Path) -> dict:
    """One model's median ms a pass on one thread, and onnxruntime's profile of those passes."""
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    opts.add_session_config_entry("session.intra_op.allow_spinning", "0")  # as d2sr.runtime.backends
    opts.enable_profiling = True
    opts.profile_file_prefix = str(prefix)
    session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    feeds = _feeds(session)
    for _ in range(3):
        session.run(None, feeds)
    ms = []
    for _ in range(runs):
        t = time.perf_counter()
        session.run(None, feeds)
        ms.append((time.perf_counter() - t) * 1000)
    events = json.loads(Path(session.end_profiling()).read_text())
    passes = runs + 3
    by_op: Counter[str] = Counter()
    convs: dict[str, dict] = {}
    for e in events:
        if e.get("cat") != "Node" or not e["name"].endswith("_kernel_time"):
            continue
        op = e["args"]["op_name"]
        by_op[op] += e["dur"]
        if op == "Conv":
            c = convs.setdefault(e["name"], {"us": 0, "args": e["args"]})
            c["us"] += e["dur"]
    total = sum(by_op.values())
    conv_rows = []
    for name, c in sorted(convs.items(), key=lambda kv: -kv[1]["us"]):
        weight = next(iter(c["args"]["input_type_shape"][1].values()))
        out = next(iter(c["args"]["output_type_shape"][0].values()))
        flops = 2 * int(np.prod(out)) * int(np.prod(weight[1:]))
        ms_pass = c["us"] / passes / 1000
        conv_rows.append(
            {
                "node": name.removesuffix("_kernel_time"),
                "weight": weight,
                "output": out,
                "ms": round(ms_pass, 3),
                "gflop": round(flops / 1e9, 4),
                "gflop_per_s": round(flops / 1e9 / (ms_pass / 1000), 1),
            }
        )
    conv_ms = sum(r["ms"] for r in conv_rows)
    conv_gflop = sum(r["gflop"] for r in conv_rows)
    return {
        "ms_per_pass": round(statistics.median(ms), 2),
        "ms_runs": [round(m, 2) for m in ms],
        "by_operator_ms": {op: round(us / passes / 1000, 3) for op, us in by_op.most_common()},
        "by_operator_share": {op: round(us / total, 3) for op, us in by_op.most_common()},
        "conv_ms": round(conv_ms, 2),
        "conv_gflop": round(conv_gflop, 3),
        "conv_gflop_per_s": round(conv_gflop / (conv_ms / 1000), 1) if conv_ms else None,
        "convs": conv_rows,
    }


def _int8(src: Path, out: Path, operator: bool, convs_only: bool) -> Path:
    """``src`` quantized as ``quantize`` does, but in onnxruntime's QOperator format (``operator``) or with
    only its convolutions quantized (``convs_only``: the pooling and resizing stay in float)."""
    from onnxruntime.quantization import CalibrationDataReader, QuantFormat, QuantType, quantize_static

    from d2sr.models.onnx.quantize import _calibration

    class Reader(CalibrationDataReader):
        def __init__(self) -> None:
            self.it = _calibration(src, 16)

        def get_next(self) -> dict[str, np.ndarray] | None:
            return next(self.it, None)

    quantize_static(
        str(src),
        str(out),
        Reader(),
        quant_format=QuantFormat.QOperator if operator else QuantFormat.QDQ,
        per_channel=True,
        op_types_to_quantize=["Conv"] if convs_only else None,
        activation_type=QuantType.QUInt8,
        weight_type=QuantType.QInt8,
    )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="timed passes per model (median)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    shipped = WEIGHTS
    unet8 = shipped / "unet8.onnx"
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        models = {
            "unet8 fp32": unet8,
            "detector fp32": shipped / "detector.onnx",
            "unet8 int8 (QDQ, as d2sr export --int8)": quantize(unet8, t / "unet8.int8.onnx"),
            "unet8 int8 (QOperator)": _int8(unet8, t / "unet8.qop.onnx", True, False),
            "unet8 int8 (QDQ, convolutions only)": _int8(unet8, t / "unet8.conv.onnx", False, True),
        }
        passes = {name: profile(path, args.runs, t / "ort") for name, path in models.items()}
    fp32 = passes["unet8 fp32"]
    result = {
        "benchmark": "issue 44: one model pass at 640x480 on one onnxruntime thread, per operator",
        "size": f"{SIZE[1]}x{SIZE[0]}",
        "threads": 1,
        "runs": args.runs,
        "passes": passes,
        "summary": {
            "unet8 ms a pass": fp32["ms_per_pass"],
            "its convolutions ms, share": [fp32["conv_ms"], round(fp32["conv_ms"] / fp32["ms_per_pass"], 3)],
            "its convolutions GFLOP/s": fp32["conv_gflop_per_s"],
            "int8 against fp32, ms a pass": {k: v["ms_per_pass"] for k, v in passes.items() if "unet8" in k},
        },
    }
    print(write_result(result, args.json, models=["unet8", "detector"]))


if __name__ == "__main__":
    main()
