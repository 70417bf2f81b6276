"""Probe (issue 78): the shipped unet8 run once on the frame at half its resolution (every second pixel of
every second row), its mask logits and depth taken back to full resolution by nearest neighbour, then
guarded and written as ``d2sr recover`` writes a repair (``contract.repair.repair_frame``). A pass at half
the resolution does a quarter of the work, full-resolution parts included; the question is what it costs in
repair. Beside it, in the same run: unet8 as recover runs it (two passes at full resolution) and one pass at
full resolution. No training; every frame of outside sets A-I repaired (``--repair all``), no scene.

Per set: the RMSE change over the corrupted frames against the clean frame (pooled), mask F1 against the
pixels the set changed, the share of unchanged pixels the repair changed, frames made worse; and one
thread's median milliseconds for the model's part (half: the pass and the resize).

``--half-models FOLDER``: the half-resolution pass runs that folder's unet8 (one fine-tuned at half
resolution, ``lab/half_train.py``), the other two the shipped one.

Run:  python -m lab.half_pass --data ../shared/data [--sets a,b] [--half-models out/half] [--json out.json]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import every_other, open_sets, outside_set

from d2sr.atomic import write_result
from d2sr.contract.catalog import padded
from d2sr.contract.repair import recover_passes, repair_frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings

SCALE = 4000.0


def _half(net, metres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mask logits, depth) at full resolution from one pass on every second pixel of every second row."""
    h, w = metres.shape[-2:]
    small = np.ascontiguousarray(metres[:, ::2, ::2])
    x = padded(small)
    logit, pred = net.raw(x, None)
    logit, pred = logit[:, : small.shape[1], : small.shape[2]], pred[:, : small.shape[1], : small.shape[2]]
    up = lambda a: np.repeat(np.repeat(a, 2, axis=1), 2, axis=2)[:, :h, :w]
    return up(logit), up(pred)


def _ways(net, half_net):
    cut = net.mask_logit

    def two(m):
        return recover_passes(net.raw, m, None, cut, 2)

    def one(m):
        return recover_passes(net.raw, m, None, cut, 1)

    def half(m):
        logit, pred = _half(half_net, m)
        return pred, logit > half_net.mask_logit

    return {"unet8, two passes (as recover)": two, "unet8, one pass": one, "unet8, one pass at half": half}


def measure(data: Path, sets: list[str], half_models: Path | None = None) -> dict:
    net = open_backend(RunSettings(backend="onnx", model="unet8", threads=1))
    half_net = net
    if half_models is not None:
        at = RunSettings(backend="onnx", model="unet8", models=half_models, threads=1)
        half_net = open_backend(at, detector=False)
    clean = outside_set(data)
    out: dict = {}
    times: dict[str, list[float]] = {}
    for which in sets:
        bad = every_other(clean, SCALE, which)
        row = {}
        for name, run in _ways(net, half_net).items():
            se0 = se1 = n = worse = changed = kept = tp = fp = fn = 0.0
            for b, c in zip(bad, clean, strict=True):
                metres = padded((b.astype(np.float32) / np.float32(SCALE))[None])
                t = time.perf_counter()
                pred, mask = run(metres)
                times.setdefault(name, []).append(time.perf_counter() - t)
                h, w = b.shape
                fixed, m = repair_frame(b, pred[0, :h, :w], mask[0, :h, :w], SCALE)
                hit = b != c
                changed += float((~hit & (fixed != b)).sum())
                kept += float((~hit).sum())
                tp, fp, fn = (
                    tp + float((m & hit).sum()),
                    fp + float((m & ~hit).sum()),
                    fn + float((~m & hit).sum()),
                )
                if not hit.any():
                    continue
                ok = c > 0
                e0 = float((((b.astype(np.float64) - c) / SCALE)[ok] ** 2).sum())
                e1 = float((((fixed.astype(np.float64) - c) / SCALE)[ok] ** 2).sum())
                se0, se1, n, worse = se0 + e0, se1 + e1, n + float(ok.sum()), worse + (e1 > e0 + 1e-9)
            row[name] = {
                "rmse_change": round(float(np.sqrt(se1 / se0) - 1), 4),
                "mask_f1": round(2 * tp / max(2 * tp + fp + fn, 1), 4),
                "clean_changed": round(changed / max(kept, 1), 5),
                "frames_worse": int(worse),
            }
        out[which] = row
        print(which, row, flush=True)
    ms = {k: round(1000 * statistics.median(v), 2) for k, v in times.items()}
    return {"sets": out, "model_ms_median_one_thread": ms}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--sets", default=",".join(open_sets()), help="outside sets, comma-separated [A-I]")
    ap.add_argument("--half-models", type=Path, default=None, help="the half pass's unet8 [the shipped]")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result = {"probe": "issue 78: unet8 once at half resolution beside two passes and one at full"}
    result |= measure(args.data, args.sets.split(","), args.half_models)
    models = ["unet8"] + ([str(args.half_models / "unet8.safetensors")] if args.half_models else [])
    print(write_result(result, args.json, models=models))


if __name__ == "__main__":
    main()
