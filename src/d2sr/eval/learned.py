"""The learned stages' held-out evaluation as a pipeline (``d2sr eval detector|recovery`` and the paper
report call it): score the test sets, write JSON, tables and plots into a folder, and, for the commands
that train or evaluate the shipped models, their model cards."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from d2sr.contract.repair import repair_frame
from d2sr.errors import ConfigError
from d2sr.eval.model_plots import error_cdf, gallery, operating_curves, pr_curves
from d2sr.eval.models import (
    TestSet,
    detector_metrics,
    generated_set,
    l515_set,
    moving_set,
    operating_curve,
    recovery_metrics,
)
from d2sr.eval.plots import save
from d2sr.models.inference import TorchBackend
from d2sr.provenance import stamp
from d2sr.ui import warn

__all__ = [
    "CURVE_LOGITS",
    "SET_TITLES",
    "detector_metrics_card",
    "detector_scores",
    "evaluate_detectors",
    "evaluate_recovery",
    "recovery_metrics_card",
    "recovery_table",
    "repair_fn",
    "write_detectors",
]

CURVE_LOGITS = tuple(float(t) for t in range(4, -7, -1))  # mask thresholds the trade-off plot walks
SET_TITLES = {
    "generated": "generated test set (seeds >= 1,000,000)",
    "l515": "real L515 dev0+dev1 with simulated interference on every other frame",
    "moving": "simulated moving robot among 3 fixed sensors (held-out room)",
}
#: A progress hook: (description, total) -> a callable that advances by one.
Progress = Callable[[str, int], Callable[[], None]]


def _quiet(_description: str, _total: int) -> Callable[[], None]:
    return lambda: None


def _real_sets(real: Path) -> list:
    """The real L515 set when ``real`` holds the captures; said aloud when it does not (a parent folder
    given by mistake would otherwise drop the real set from the figures without a word)."""
    if (real / "dev0").is_dir():
        return [l515_set(real)]
    warn(f"{real}: no dev0/ capture here, so no real L515 set in these figures (--real ../shared/data/l515)")
    return []


def evaluate_detectors(
    names: list[str], weights: Path, real: Path, cache: Path, threshold: float, progress: Progress = _quiet
) -> dict[str, dict]:
    """``<model>/<set>`` -> precision, recall, false alarms and PR curve, for each detector whose weights
    exist, on the generated test set and (when ``real`` holds dev0/) the real L515 set."""
    sets = [generated_set(cache), *_real_sets(real)]
    results: dict[str, dict] = {}
    for name in names:
        path = weights / f"{name}.safetensors"
        if not path.is_file():
            continue
        net = TorchBackend(path, None)
        for ts in sets:
            scores = detector_scores(net, ts, progress(f"{name} on {ts.name}", len(ts.frames)))
            results[f"{name}/{ts.name}"] = detector_metrics(scores, ts, threshold)
    return results


def detector_scores(net: TorchBackend, ts: TestSet, step: Callable[[], None] | None = None) -> np.ndarray:
    """The detector's score of each frame of ``ts`` in order, given the frame delivered before it (a
    temporal detector's second input; others ignore it)."""
    scores = []
    for i in range(len(ts.frames)):
        b = ts.before(i)
        scores.append(float(net.scores(ts.metres(i)[None], None if b is None else b[None])[0]))
        if step is not None:
            step()
    return np.array(scores)


def write_detectors(results: dict[str, dict], folder: Path, weights: Path) -> None:
    """detector.json (stamped with the models' hashes in ``weights``) and its precision-recall plot."""
    save(pr_curves(results), folder / "pr.png")
    models = list(dict.fromkeys(k.split("/")[0] for k in results))
    text = json.dumps(stamp(results, models=models, folder=weights), indent=1)
    (folder / "detector.json").write_text(text + "\n")


def detector_metrics_card(results: dict[str, dict], name: str) -> dict[str, str]:
    """Detector ``name``'s figures in ``detector.json``'s ``results`` as its card quotes them."""
    return {
        f"{SET_TITLES[k.split('/')[1]]}: precision / recall / false alarms": (
            f"{r['precision']:.3f} / {r['recall']:.3f} / {r['false_alarm_rate']:.3f}"
        )
        for k, r in results.items()
        if k.startswith(name + "/") and k.split("/")[1] in SET_TITLES
    }


def repair_fn(net: TorchBackend) -> Callable:
    """A recovery model as ``eval.models.Repair``: one pass, written back as ``recover`` writes it."""

    def fn(x: np.ndarray, prev: np.ndarray | None, scale: float) -> tuple[np.ndarray, np.ndarray]:
        pred, mask = net.recover(x[None], None if prev is None else prev[None])
        units, kept = repair_frame(np.rint(x * scale).astype(np.uint16), pred[0], mask[0], scale)
        return units.astype(np.float32) / np.float32(scale), kept

    return fn


def evaluate_recovery(
    names: list[str],
    weights: Path,
    real: Path,
    cache: Path,
    limit: int,
    folder: Path,
    progress: Progress = _quiet,
) -> dict:
    """Recovery on each test set's interfered frames (RMSE, mask F1, clean pixels changed, classical
    baselines given the first model's mask) and the first model's mask-threshold trade-off; error CDFs,
    galleries and the trade-off plot go into ``folder``, ``recovery.json`` too. Returns what it wrote."""
    nets = {
        n: TorchBackend(None, weights / f"{n}.safetensors")
        for n in names
        if (weights / f"{n}.safetensors").is_file()
    }
    if not nets:
        raise ConfigError(f"no recovery weights for {', '.join(names)} in {weights}")
    first = next(iter(nets))
    logits = sorted({*CURVE_LOGITS, nets[first].mask_logit}, reverse=True)  # the model's own on the curve

    def raw(x: np.ndarray, prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        logit, pred = nets[first].raw(x[None], None if prev is None else prev[None])
        return logit[0], pred[0]

    sets = [*_real_sets(real), generated_set(cache), moving_set()]
    tables: dict[str, dict] = {}
    curves: dict[str, dict] = {}
    for ts in sets:
        fns = {k: repair_fn(v) for k, v in nets.items()}
        n = int(ts.labels.sum()) if not limit else min(limit, int(ts.labels.sum()))
        rows, errors = recovery_metrics(ts, fns, first, n, progress(f"recovery on {ts.name}", n))
        tables[ts.name] = rows
        curves[ts.name] = operating_curve(ts, raw, logits, n)
        keep = [
            "identity",
            *fns,
            *(f"{b} (predicted mask)" for b in ("median", "nearest", "ip-basic", "inpaint")),
        ]
        cdf = error_cdf({k: errors[k] for k in keep if k in errors}, f"Per-pixel error, {ts.name}")
        save(cdf, folder / f"error_cdf_{ts.name}.png")
        save(gallery(_gallery_rows(ts, fns[first])), folder / f"gallery_{ts.name}.png")
    save(operating_curves(curves, nets[first].mask_logit, first), folder / "operating_curve.png")
    result = tables | {"operating_curve": {first: curves}}
    text = json.dumps(stamp(result, models=names, folder=weights), indent=1)
    (folder / "recovery.json").write_text(text + "\n")
    table = recovery_table(tables, first)
    (folder / "table.md").write_text(table)
    return {"tables": tables, "curves": curves, "first": first, "table": table}


def _gallery_rows(ts: TestSet, fn: Callable) -> list[tuple]:
    idx = [int(i) for i in np.flatnonzero(ts.labels)][:: max(1, int(ts.labels.sum()) // 4)][:4]
    rows = []
    for i in idx:
        x = ts.metres(i)
        y = ts.metres(i, clean=True)
        o, m = fn(x, ts.previous(i), ts.scale_at(i))
        rows.append((f"{ts.name} #{i}", x, ts.frames[i] != ts.clean[i], m, o, y))
    return rows


def recovery_table(tables: dict[str, dict], first: str) -> str:
    lines = []
    for set_name, rows in tables.items():
        lines += [
            f"### {set_name}",
            "",
            "| method | RMSE (cm) | vs identity | mask precision | mask recall | mask F1 "
            "| clean px changed >1 cm |",
            "|---|---|---|---|---|---|---|",
        ]
        for k, r in rows.items():
            lines.append(
                f"| {k} | {r['rmse_cm']:.2f} | {100 * r['rmse_vs_identity']:+.1f}% "
                f"| {r['mask_precision']:.3f} | {r['mask_recall']:.3f} | {r['mask_f1']:.3f} "
                f"| {100 * r['clean_changed']:.2f}% |"
            )
        lines.append("")
    lines += [f"Mask threshold trade-off of {first}: [operating_curve.png](operating_curve.png)", ""]
    return "\n".join(lines)


def recovery_metrics_card(tables: dict[str, dict], name: str) -> dict[str, str]:
    """Recovery model ``name``'s figures in ``recovery.json``'s per-set ``tables`` as its card quotes them."""
    return {
        f"{SET_TITLES[s]}: RMSE cm (vs identity) / mask F1 / clean px changed": (
            f"{t[name]['rmse_cm']:.2f} ({100 * t[name]['rmse_vs_identity']:+.1f}%) / "
            f"{t[name]['mask_f1']:.3f} / {100 * t[name]['clean_changed']:.2f}%"
        )
        for s, t in tables.items()
        if name in t
    }
