"""Benchmark (issue 45): do the real L515 figures flatter a model because the simulator that made its
training data was fitted to those same captures?

Each recipe (configs/overlap/; unet8 in two stages) is trained twice from scratch, on data from the simulator
fitted to L515 dev0 alone and to dev1 alone (``d2sr calibrate``). Each model is judged on each view of ``d2sr
eval``'s real L515 set (every other frame interfered): on the view its simulator never saw (held out) and on
the one it was fitted to. The shipped models (simulator fitted to both views, a longer recipe) are measured
beside them.

Run:  make overlap   (calibrates, trains the models of both views, then runs this)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.contract.catalog import THRESHOLD, WEIGHTS
from d2sr.errors import D2SRError
from d2sr.eval.learned import detector_scores, repair_fn
from d2sr.eval.models import TestSet, detector_metrics, l515_set, recovery_metrics
from d2sr.models.inference import TorchBackend

VIEWS = ("dev0", "dev1")
RECIPES = ("detector", "unet8-stage1", "unet8")
KEEP = ("rmse_cm", "rmse_vs_identity", "mask_f1", "clean_changed")


def _fits(runs: Path, model: str) -> dict[str, Path]:
    """Each model's weights by the captures its simulator was fitted to."""
    paths = {f"fit {v}": runs / f"{model}-{v}" / f"{model}.safetensors" for v in VIEWS}
    return paths | {"fit both (shipped)": WEIGHTS / f"{model}.safetensors"}


def detector(ts: TestSet, path: Path) -> dict:
    out = detector_metrics(detector_scores(TorchBackend(path, None), ts), ts, THRESHOLD)
    out.pop("pr_curve")
    return out


def recovery(ts: TestSet, paths: dict[str, Path], limit: int) -> dict:
    fns = {k: repair_fn(TorchBackend(None, p)) for k, p in paths.items()}
    rows, _ = recovery_metrics(ts, fns, None, limit)
    frames = min(limit, int(ts.labels.sum()))
    return {k: {m: rows[k][m] for m in KEEP} | {"frames": frames} for k in ("identity", *fns)}


def held_out_gap(per_view: dict[str, dict], metric: str) -> dict[str, float]:
    """Per view: the held-out model's figure minus the fitted one's (same recipe)."""
    out = {}
    for v in VIEWS:
        other = next(w for w in VIEWS if w != v)
        out[v] = round(per_view[v][f"fit {other}"][metric] - per_view[v][f"fit {v}"][metric], 4)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", type=Path, default=Path("../shared/data/l515"))
    ap.add_argument("--runs", type=Path, default=Path("runs/overlap"))
    ap.add_argument("--limit", type=int, default=40, help="interfered frames per view for recovery")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    dets, recs = _fits(args.runs, "detector"), _fits(args.runs, "unet8")
    missing = [str(p) for p in (*dets.values(), *recs.values()) if not p.is_file()]
    if missing:
        ap.error(f"no weights at {', '.join(missing)}: run make overlap")
    try:
        both = l515_set(args.real)
    except D2SRError as exc:
        ap.error(str(exc))
    views = {v: both.sequence(k, f"l515-{v}") for k, v in enumerate(VIEWS)}
    detection = {v: {k: detector(ts, p) for k, p in dets.items()} for v, ts in views.items()}
    repair = {v: recovery(ts, recs, args.limit) for v, ts in views.items()}
    result = {
        "views": {v: {"frames": len(t.frames), "interfered": int(t.labels.sum())} for v, t in views.items()},
        "detector": detection,
        "recovery": repair,
        "held_out_minus_fitted": {
            "detector false alarms": held_out_gap(detection, "false_alarm_rate"),
            "detector recall": held_out_gap(detection, "recall"),
            "unet8 RMSE vs identity": held_out_gap(repair, "rmse_vs_identity"),
            "unet8 mask F1": held_out_gap(repair, "mask_f1"),
        },
        "recipes": [f"configs/overlap/{k}-{v}.toml" for k in RECIPES for v in VIEWS],
    }
    models = [*dets.values(), *recs.values()]
    print(write_result(result, args.json, models=models, data="real L515 dev0, dev1 (d2sr eval's set)"))


if __name__ == "__main__":
    main()
