"""Benchmark: where the error left on the outside L515 set lies (``held_out.py``'s corrupted frames, in
process, ``recover --repair all``'s repair): the squared error left in pixels the mask misses, in pixels it
repairs and in clean pixels; the RMSE change with the true mask in place of the predicted one (the same
guarded predictions: what a perfect mask would give this model); the first pass's mask logits at missed,
repaired and clean returning pixels; by the share of a frame's pixels hit (``HIT_BUCKETS``), the frames, the
mask's recall and the share of the missed pixels' error; the same by what the interference did to a pixel
(``ERROR_KINDS``: no return, too short or too far by its ratio to the truth); the RMSE change for each number
of passes in
``--passes``; and with
``--plot``, the trade-off ``--mask-logit`` walks (RMSE change against clean pixels changed, both passes,
per threshold).

Run:  python -m lab.outside_error --data ../shared/data \
          --json lab/notes/results/outside_error.json --plot lab/notes/results/outside_error.png
      python -m lab.outside_error --models DIR --model unet8-temporal   (given the last frame)
"""

from __future__ import annotations

import argparse
from itertools import pairwise
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args

from d2sr.contract.catalog import WEIGHTS
from d2sr.contract.metrics import RepairSums
from d2sr.contract.repair import repair_frame
from d2sr.errors import D2SRError, InputError
from d2sr.eval.model_plots import operating_curves
from d2sr.eval.plots import save
from d2sr.eval.speed import write_result
from d2sr.runtime.backends import Backend, open_backend
from lab.held_out import SETS, every_other, outside_set

SCALE = 4000.0
QUANTILES = (5, 25, 50, 75, 95)
HIT_BUCKETS = (0.0, 0.02, 0.1, 0.3, 1.0)  # share of a frame's returning pixels the interference changed
# What the interference did to a returning pixel: (name, lowest, highest ratio of its value to the truth).
ERROR_KINDS = (
    ("no return", 0.0, 0.0),
    ("too short, under 0.5x", 1e-9, 0.5),
    ("too short, 0.5-0.8x", 0.5, 0.8),
    ("too short, 0.8-1x", 0.8, 1.0),
    ("too far, 1-1.25x", 1.0, 1.25),
    ("too far, over 1.25x", 1.25, np.inf),
)
LOGITS = (3.0, 2.0, 1.0, 0.5, 0.0, -0.5, -1.0, -1.5, -2.0, -3.0, -4.0)  # --plot's thresholds


Pairs = list[tuple[np.ndarray, np.ndarray, np.ndarray]]  # (corrupted, clean, clean frame before)


def _pairs(data: Path, which: str) -> Pairs:
    """(corrupted frame, its clean frame, the clean frame before it) for the frames set ``which``'s
    interference changed (``held_out.scored``'s: of the 60 it is written on, some are left as they were)."""
    clean = outside_set(data)
    if len(clean) < 2:
        raise InputError(f"{data}/l515: needs the dev0 and dev1 captures (found {len(clean)} frames)")
    bad = every_other(clean, SCALE, which)
    return [(bad[i], clean[i], clean[i - 1]) for i in range(1, len(clean), 2) if (bad[i] != clean[i]).any()]


def _sq(out: np.ndarray, clean: np.ndarray, where: np.ndarray) -> float:
    return float((((out.astype(np.float64) - clean) / SCALE)[where] ** 2).sum())


def breakdown(weights: Path, model: str, pairs: Pairs, passes: list[int]) -> dict:
    """The figures above for one model (a temporal one gets the clean frame before each, as a still sensor's
    last clean frame)."""
    net = open_backend(model, "onnx", weights, detector=None)
    before = sum(_sq(b, c, c > 0) for b, c, _ in pairs)
    parts = {"missed": 0.0, "repaired": 0.0, "clean": 0.0}
    ceiling = 0.0
    logits: dict[str, list[np.ndarray]] = {"missed": [], "repaired": [], "clean": []}
    frames = []  # (share of the frame hit, hit pixels repaired, hit pixels, missed pixels' squared error)
    kinds = np.zeros((len(ERROR_KINDS), 3))  # per ERROR_KINDS: hit pixels, repaired, missed squared error
    for b, c, prev in pairs:
        metres = b.astype(np.float32)[None] / np.float32(SCALE)
        last = prev.astype(np.float32)[None] / np.float32(SCALE) if net.frames == 2 else None
        pred, mask = net.recover(metres, last)
        out, kept = repair_frame(b, pred[0], mask[0], SCALE)
        true, ok = b != c, c > 0
        parts["missed"] += _sq(out, c, ok & true & ~kept)
        parts["repaired"] += _sq(out, c, ok & true & kept)
        parts["clean"] += _sq(out, c, ok & ~true)
        hit = ok & true
        frames.append((hit.sum() / max(ok.sum(), 1), (hit & kept).sum(), hit.sum(), _sq(out, c, hit & ~kept)))
        ceiling += _sq(repair_frame(b, pred[0], true, SCALE)[0], c, ok)
        ratio = b / np.maximum(c, 1).astype(np.float64)
        for k, (_, lo, hi) in enumerate(ERROR_KINDS):
            at = hit & ((ratio == 0) if hi == 0 else (ratio > lo) & (ratio <= hi))
            kinds[k] += (at.sum(), (at & kept).sum(), _sq(out, c, at & ~kept))
        logit = net.raw(metres, last)[0][0]
        logits["missed"].append(logit[true & ~kept])
        logits["repaired"].append(logit[true & kept])
        logits["clean"].append(logit[~true & (b > 0)])
    left = sum(parts.values())
    runs = {n: open_backend(model, "onnx", weights, detector=None, passes=n) for n in passes}
    by_passes = {str(n): _repaired(b, pairs)[0] for n, b in runs.items()}
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
        "by_frame_hit": _by_frame_hit(np.array(frames, np.float64)),
        "by_error": {
            name: {
                "pixels_share": round(float(n / max(kinds[:, 0].sum(), 1)), 4),
                "recall": round(float(found / max(n, 1)), 4),
                "missed_error_share": round(float(err / max(kinds[:, 2].sum(), 1e-12)), 4),
            }
            for (name, _, _), (n, found, err) in zip(ERROR_KINDS, kinds, strict=True)
        },
        "rmse_change_by_passes": by_passes,
    }


def _by_frame_hit(rows: np.ndarray) -> dict[str, dict[str, float]]:
    """Per ``HIT_BUCKETS`` range of a frame's share of pixels hit: frames, the mask's recall over their hit
    pixels, and their share of the error left in missed pixels."""
    out = {}
    missed = max(float(rows[:, 3].sum()), 1e-12)
    for lo, hi in pairwise(HIT_BUCKETS):
        r = rows[(rows[:, 0] >= lo) & ((rows[:, 0] < hi) | (hi == HIT_BUCKETS[-1]))]
        out[f"{lo:g}-{hi:g}"] = {
            "frames": len(r),
            "recall": round(float(r[:, 1].sum() / max(r[:, 2].sum(), 1)), 4),
            "missed_error_share": round(float(r[:, 3].sum()) / missed, 4),
        }
    return out


def _repaired(net: Backend, pairs: Pairs) -> tuple[float, ...]:
    """(RMSE change, share of clean pixels changed, mask F1) of ``net``'s repair of the pairs, in the sums
    every evaluation uses (``metrics.RepairSums``)."""
    before, after = RepairSums(), RepairSums()
    for b, c, prev in pairs:
        x, y = b.astype(np.float32) / np.float32(SCALE), c.astype(np.float32) / np.float32(SCALE)
        last = prev.astype(np.float32)[None] / np.float32(SCALE) if net.frames == 2 else None
        pred, mask = net.recover(x[None], last)
        out, kept = repair_frame(b, pred[0], mask[0], SCALE)
        true = b != c
        before.add(x, np.zeros_like(true), x, y, true)
        after.add(out.astype(np.float32) / np.float32(SCALE), kept, x, y, true)
    r = after.result()
    change = r["rmse_cm"] / before.result()["rmse_cm"] - 1
    return round(change, 4), round(r["clean_changed"], 5), round(r["mask_f1"], 4)


def curve(weights: Path, model: str, pairs: Pairs, own: float) -> dict[str, list[float]]:
    """``operating_curve``'s figures on the outside set, as recover repairs (both passes), per threshold
    (``LOGITS`` and the model's ``own``)."""
    logits = sorted({*LOGITS, own}, reverse=True)
    rows = [
        _repaired(open_backend(model, "onnx", weights, detector=None, mask_logit=t), pairs) for t in logits
    ]
    return {
        "mask_logit": logits,
        "rmse_vs_identity": [r[0] for r in rows],
        "clean_changed": [r[1] for r in rows],
        "mask_f1": [r[2] for r in rows],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--models", type=Path, default=WEIGHTS, help="a model folder (default: shipped)")
    ap.add_argument("--model", default="unet8")
    ap.add_argument("--set", choices=sorted(SETS), default="a", help="held_out.py's outside set")
    ap.add_argument("--passes", default="1,2,3,4", help="numbers of passes to compare, comma-separated")
    output_args(ap, plot="also write the trade-off plot (PNG) here")
    args = ap.parse_args()
    check_output(ap, args)
    try:
        passes = [int(p) for p in args.passes.split(",") if p.strip()]
        pairs = _pairs(args.data, args.set)
        result = breakdown(args.models, args.model, pairs, passes)
        if args.plot is not None:
            result["operating_curve"] = curve(args.models, args.model, pairs, result["mask_logit"])
    except (D2SRError, ValueError) as exc:
        ap.error(str(exc))
    result["set"] = args.set
    if args.plot is not None:
        name = f"outside L515 set {args.set}"
        save(operating_curves({name: result["operating_curve"]}, result["mask_logit"], args.model), args.plot)
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
