"""Benchmark: where the error left on the outside L515 set lies (``held_out.py``'s 60 corrupted frames, in
process, ``recover --all``'s repair): the squared error left in pixels the mask misses, in pixels it repairs,
and in clean pixels; the RMSE change with the true mask in place of the predicted one (the same guarded
predictions: what a perfect mask would give this model); the first pass's mask logits at missed, repaired
and clean returning pixels; and the RMSE change for each number of passes in ``--passes``.

Run:  .venv/bin/python bench/outside_error.py --data ../shared/data --json docs/results/outside_error.json
      .venv/bin/python bench/outside_error.py --models DIR --model unet8-temporal   (given the last frame)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from d2sr.bench import check_output, output_args, write_result
from d2sr.contract import WEIGHTS, repair_frame
from d2sr.inference import open_backend
from held_out import every_other, outside_set

SCALE = 4000.0
QUANTILES = (5, 25, 50, 75, 95)


def _sq(out: np.ndarray, clean: np.ndarray, where: np.ndarray) -> float:
    return float((((out.astype(np.float64) - clean) / SCALE)[where] ** 2).sum())


def breakdown(weights: Path, model: str, data: Path, passes: list[int]) -> dict:
    """The figures above for one model (a temporal one gets the clean frame before each, as a still sensor's
    last clean frame)."""
    clean = outside_set(data)
    bad = every_other(clean, SCALE)
    pairs = [(bad[i], clean[i], clean[i - 1]) for i in range(1, len(clean), 2)]
    net = open_backend(model, "onnx", weights, detector=None)
    before = sum(_sq(b, c, c > 0) for b, c, _ in pairs)
    parts = {"missed": 0.0, "repaired": 0.0, "clean": 0.0}
    ceiling = 0.0
    logits: dict[str, list[np.ndarray]] = {"missed": [], "repaired": [], "clean": []}
    for b, c, prev in pairs:
        metres = b.astype(np.float32)[None] / np.float32(SCALE)
        last = prev.astype(np.float32)[None] / np.float32(SCALE) if net.frames == 2 else None
        pred, mask = net.recover(metres, last)
        out, kept = repair_frame(b, pred[0], mask[0], SCALE)
        true, ok = b != c, c > 0
        parts["missed"] += _sq(out, c, ok & true & ~kept)
        parts["repaired"] += _sq(out, c, ok & true & kept)
        parts["clean"] += _sq(out, c, ok & ~true)
        ceiling += _sq(repair_frame(b, pred[0], true, SCALE)[0], c, ok)
        logit = net.raw(metres, last)[0][0]
        logits["missed"].append(logit[true & ~kept])
        logits["repaired"].append(logit[true & kept])
        logits["clean"].append(logit[~true & (b > 0)])
    left = sum(parts.values())
    by_passes = {}
    for n in passes:
        pn = open_backend(model, "onnx", weights, detector=None, passes=n)
        err = 0.0
        for b, c, prev in pairs:
            last = prev.astype(np.float32)[None] / np.float32(SCALE) if pn.frames == 2 else None
            pred, mask = pn.recover(b.astype(np.float32)[None] / np.float32(SCALE), last)
            err += _sq(repair_frame(b, pred[0], mask[0], SCALE)[0], c, c > 0)
        by_passes[str(n)] = round(float(np.sqrt(err / before) - 1), 4)
    return {
        "model": model,
        "frames": len(pairs),
        "mask_logit": net.mask_logit,
        "rmse_change": round(float(np.sqrt(left / before) - 1), 4),
        "rmse_change_true_mask": round(float(np.sqrt(ceiling / before) - 1), 4),
        "error_left_share": {k: round(v / max(left, 1e-12), 4) for k, v in parts.items()},
        "logit_percentiles": {
            k: dict(
                zip(
                    map(str, QUANTILES),
                    np.percentile(np.concatenate(v), QUANTILES).round(2).tolist(),
                    strict=True,
                )
            )
            for k, v in logits.items()
        },
        "rmse_change_by_passes": by_passes,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--models", type=Path, default=WEIGHTS, help="a model folder (default: shipped)")
    ap.add_argument("--model", default="unet8")
    ap.add_argument("--passes", default="1,2,3,4", help="numbers of passes to compare, comma-separated")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    passes = [int(p) for p in args.passes.split(",") if p.strip()]
    print(write_result(breakdown(args.models, args.model, args.data, passes), args.json))


if __name__ == "__main__":
    main()
