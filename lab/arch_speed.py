"""Benchmark (issue 44): how much lighter a recovery UNet can get by its widths alone. Each candidate
layout of ``d2sr.models.unet.UNet`` (random weights: speed does not depend on them) is exported as d2sr
exports the shipped ones and run by onnxruntime on a 640x480 frame, on one thread and on two, alternating
candidates so that a noisy machine slows all alike; the median of ``--repeats`` runs per candidate. Then
each candidate's kernels on one thread, summed by operator (onnxruntime's profiler): what the convolutions
take, and what the full-resolution work around them (the input's features, the space-to-depth, the heads'
depth-to-space, the push-pull fill) takes whatever the widths.

Run:  python -m lab.arch_speed --json docs/results/arch_speed.json
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import onnxruntime as ort
import torch
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.models.onnx.export import _onnx
from d2sr.models.unet import UNet

# name: UNet's keywords (fill=True; s2d=4 unless given: the shipped layout). The first is unet8 as shipped.
# Issue 44's widths; issue 78's folds of 8x8 blocks (the trunk at 80x60), toward a quarter of unet8's pass.
CANDIDATES: dict[str, dict[str, int]] = {
    "unet8 (shipped)": {"width": 8},
    "unet8, head 32": {"width": 8, "hidden": 32},
    "unet6, head 32": {"width": 6, "hidden": 32},
    "unet4": {"width": 4},
    "unet4, head 32": {"width": 4, "hidden": 32},
    "unet4, head 16": {"width": 4, "hidden": 16},
    "s2d 8, unet16": {"width": 16, "s2d": 8},
    "s2d 8, unet8": {"width": 8, "s2d": 8},
    "s2d 8, unet8, head 64": {"width": 8, "s2d": 8, "hidden": 64},
}
CONV = "Conv"


def _session(path: Path, threads: int, profile: str | None = None) -> ort.InferenceSession:
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.add_session_config_entry("session.intra_op.allow_spinning", "0")  # as d2sr's backends run
    if profile is not None:
        opts.enable_profiling = True
        opts.profile_file_prefix = profile
    return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])


def _by_operator(path: Path, x: np.ndarray, runs: int, tmp: Path) -> dict[str, float]:
    """ms a run on one thread, by operator, from onnxruntime's profile of ``runs`` runs."""
    s = _session(path, 1, str(tmp / "profile"))
    for _ in range(runs):
        s.run(None, {"depth": x})
    trace = Path(s.end_profiling())
    total: dict[str, float] = defaultdict(float)
    for e in json.loads(trace.read_text()):
        if e.get("cat") == "Node" and e["name"].endswith("_kernel_time"):
            total[e["args"]["op_name"]] += e["dur"] / 1000 / runs
    trace.unlink()
    return dict(sorted(total.items(), key=lambda kv: -kv[1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    torch.manual_seed(0)
    x = np.random.default_rng(0).uniform(0, 5, (1, 1, 480, 640)).astype(np.float32)
    out: dict = {}
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        files, params, inputs = {}, {}, {}
        for name, kw in CANDIDATES.items():
            net = UNet(**{"s2d": 4, **kw}, fill=True).eval()
            # The frame padded to the model's stride, as the runtime pads it (480 rows: 512 at stride 64).
            rows = -(-x.shape[2] // net.stride) * net.stride
            inputs[name] = np.pad(x, ((0, 0), (0, 0), (0, rows - x.shape[2]), (0, 0)))
            files[name] = tmp / f"{len(files)}.onnx"
            one = (torch.from_numpy(inputs[name]),)
            _onnx(net, one, files[name], ["depth"], ["mask_logit", "pred_depth"], {})
            params[name] = sum(p.numel() for p in net.parameters())
        times: dict[tuple[str, int], list[float]] = defaultdict(list)
        sessions = {(n, k): _session(f, k) for n, f in files.items() for k in (1, 2)}
        for (n, _), s in sessions.items():
            for _ in range(3):
                s.run(None, {"depth": inputs[n]})
        for _ in range(args.repeats):
            for key, s in sessions.items():
                t0 = time.perf_counter()
                s.run(None, {"depth": inputs[key[0]]})
                times[key].append(1000 * (time.perf_counter() - t0))
        first = next(iter(CANDIDATES))
        for name in CANDIDATES:
            ops = _by_operator(files[name], inputs[name], 10, tmp)
            conv = ops.get(CONV, 0.0)
            one = statistics.median(times[(name, 1)])
            out[name] = {
                "keywords": CANDIDATES[name],
                "parameters": params[name],
                "ms_one_thread": round(one, 2),
                "ms_two_threads": round(statistics.median(times[(name, 2)]), 2),
                "speedup_one_thread": round(statistics.median(times[(first, 1)]) / one, 2),
                "profile_ms_one_thread": {
                    "convolutions": round(conv, 2),
                    "everything else": round(sum(ops.values()) - conv, 2),
                    "by_operator": {k: round(v, 3) for k, v in list(ops.items())[:10]},
                },
            }
            print(name, json.dumps(out[name]), flush=True)
    result = {
        "benchmark": "issue 44: one pass of candidate recovery UNets at 640x480, random weights, onnxruntime",
        "repeats": args.repeats,
        "candidates": out,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
