"""``d2sr train`` and ``d2sr export``."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from d2sr.atomic import check_out
from d2sr.cli_common import Cache, Overwrite, Real, Weights, out_dir, split_list
from d2sr.errors import ConfigError
from d2sr.runtime.backends import THRESHOLD, WEIGHTS
from d2sr.ui import console

__all__ = ["export", "train"]


def train(
    task: Annotated[str, typer.Argument(help="detector or recovery.")],
    out: Annotated[Path, typer.Option(help="Run folder: checkpoint.pt, <model>.safetensors and its card.")],
    config: Annotated[Path | None, typer.Option(help="TOML file of TrainConfig settings.")] = None,
    model: Annotated[str | None, typer.Option(help="Model name (overrides the config).")] = None,
    steps: Annotated[int | None, typer.Option(help="Training steps (overrides the config).")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed (overrides the config).")] = None,
    synthetic: Annotated[int | None, typer.Option(help="Generated frames (overrides the config).")] = None,
    minutes: Annotated[float | None, typer.Option(help="Stop after this many minutes (0: none).")] = None,
    overwrite: Overwrite = False,
) -> None:
    """Train the detector or a recovery UNet (resumes from OUT/checkpoint.pt; torchrun: several processes)."""
    from d2sr.config import read_toml
    from d2sr.train.config import TrainConfig
    from d2sr.train.loop import train as run

    if task not in ("detector", "recovery"):
        raise ConfigError(f"task must be detector or recovery, got {task!r}")
    values: dict = {} if config is None else read_toml(config)
    values["task"] = task
    values.setdefault("model", "detector" if task == "detector" else "unet8")
    for key, v in (
        ("model", model),
        ("steps", steps),
        ("seed", seed),
        ("synthetic", synthetic),
        ("time_limit_min", minutes),
    ):
        if v is not None:
            values[key] = v
    cfg = TrainConfig.make(**values)
    inputs = [p for f in cfg.folders for p in (f.input, f.target)]
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs, resume=True)
    command = "d2sr " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    summary = run(cfg, out, command)
    console.print(
        f"{cfg.model}: {summary['steps']} steps in {summary['minutes']} min, loss {summary['final_loss']}"
    )


def export(
    weights: Annotated[
        list[Path] | None, typer.Argument(help="Weights files (default: every shipped model).")
    ] = None,
    out: Annotated[
        Path | None, typer.Option(help="Folder for the .onnx files (default: next to the weights).")
    ] = None,
    int8: Annotated[
        bool, typer.Option("--int8", help="Also write <model>.int8.onnx (static int8, onnxruntime).")
    ] = False,
    overwrite: Overwrite = False,
) -> None:
    """Export models to ONNX (dynamic batch, height, width) after a parity check against torch."""
    from d2sr.export import export as run
    from d2sr.quantize import quantize

    files = weights or sorted(WEIGHTS.glob("*.safetensors"))
    if not files:
        raise ConfigError("no weights to export")
    targets = [(out or w.parent) / (w.stem + ".onnx") for w in files]
    for t in targets:
        check_out(t, is_dir=False, overwrite=overwrite, inputs=files)
        if int8:
            check_out(t.with_suffix(".int8.onnx"), is_dir=False, overwrite=overwrite)
    for w, target in zip(files, targets, strict=True):
        r = run(w, target)
        console.print(f"{w.name} -> {target} (max |onnx - torch| = {r['max_abs_diff']:.1e})")
        if int8:
            console.print(f"  int8 -> {quantize(target)}")


REAL = Path("../shared/data/l515")
CACHE = Path("out/data")
CURVE_LOGITS = tuple(float(t) for t in range(4, -7, -1))  # mask thresholds the trade-off plot walks
SET_TITLES = {
    "generated": "generated test set (seeds >= 1,000,000)",
    "l515": "real L515 dev0+dev1 with simulated interference on every other frame",
    "moving": "simulated moving robot among 3 fixed sensors (held-out room)",
}


def eval_detector(
    out: Annotated[Path, typer.Option(help="Folder for detector.json and pr.png.")] = Path(
        "docs/results/detector"
    ),
    models: Annotated[
        str, typer.Option(help="Detectors to evaluate (comma-separated).")
    ] = "detector,paper-detector",
    weights: Weights = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    threshold: Annotated[float, typer.Option(help="Operating threshold.")] = THRESHOLD,
    card: Annotated[bool, typer.Option(help="Write the metrics into the model cards.")] = True,
    overwrite: Overwrite = False,
) -> None:
    """Detector precision/recall on the generated test set and on real L515 frames with simulated
    interference; PR curves."""
    import json

    import numpy as np

    from d2sr.eval.model_plots import pr_curves
    from d2sr.eval.models import detector_metrics, generated_set, l515_set
    from d2sr.eval.plots import save
    from d2sr.models.inference import TorchBackend
    from d2sr.models.weights import write_card
    from d2sr.ui import progress_bar

    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    wdir = weights
    sets = [generated_set(cache)] + ([l515_set(real)] if (real / "dev0").is_dir() else [])
    results: dict[str, dict] = {}
    with progress_bar() as bar:
        for name in split_list(models, "models"):
            path = wdir / f"{name}.safetensors"
            if not path.is_file():
                console.print(f"[yellow]skipping {name}: no {path}[/yellow]")
                continue
            net = TorchBackend(path, None)
            for ts in sets:
                task = bar.add_task(f"{name} on {ts.name}", total=len(ts.frames))
                scores = []
                for i in range(len(ts.frames)):
                    scores.append(float(net.scores(ts.metres(i)[None])[0]))
                    bar.advance(task)
                results[f"{name}/{ts.name}"] = detector_metrics(np.array(scores), ts, threshold)
            if card:
                write_card(
                    path,
                    evaluation=f"d2sr eval detector --models {name}",
                    metrics={
                        f"{SET_TITLES[k.split('/')[1]]}: precision / recall / false alarms": (
                            f"{r['precision']:.3f} / {r['recall']:.3f} / {r['false_alarm_rate']:.3f}"
                        )
                        for k, r in results.items()
                        if k.startswith(name + "/")
                    },
                )
    slim = {k: {m: v for m, v in r.items() if m != "pr_curve"} for k, r in results.items()}
    with out_dir(out, overwrite, [real]) as tmp:
        save(pr_curves(results), tmp / "pr.png")
        (tmp / "detector.json").write_text(json.dumps(results, indent=1) + "\n")
    for k, r in slim.items():
        extra = f", people {r['false_alarm_rate_people']:.3f}" if "false_alarm_rate_people" in r else ""
        console.print(
            f"{k}: precision {r['precision']:.4f} recall {r['recall']:.4f} f1 {r['f1']:.4f} "
            f"false alarms {r['false_alarm_rate']:.4f}{extra} ({r['frames']} frames)"
        )


def eval_recovery(
    out: Annotated[Path, typer.Option(help="Folder for recovery.json, tables and plots.")] = Path(
        "docs/results/recovery"
    ),
    models: Annotated[
        str, typer.Option(help="Recovery models (comma-separated).")
    ] = "unet8,unet16,unet32,unet8-temporal",
    weights: Weights = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    limit: Annotated[int, typer.Option(help="Interfered frames per test set (0: all).")] = 0,
    card: Annotated[bool, typer.Option(help="Write the metrics into the model cards.")] = True,
    overwrite: Overwrite = False,
) -> None:
    """Recovery on interfered frames: RMSE, mask F1, clean pixels changed; baselines; error CDF; gallery."""
    import json

    import numpy as np

    from d2sr.eval.model_plots import error_cdf, gallery, operating_curves
    from d2sr.eval.models import generated_set, l515_set, moving_set, operating_curve, recovery_metrics
    from d2sr.eval.plots import save
    from d2sr.models.inference import TorchBackend
    from d2sr.models.weights import write_card
    from d2sr.runtime.backends import to_depth_units
    from d2sr.ui import progress_bar

    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    wdir = weights
    nets = {
        name: TorchBackend(None, wdir / f"{name}.safetensors")
        for name in split_list(models, "models")
        if (wdir / f"{name}.safetensors").is_file()
    }
    if not nets:
        raise ConfigError(f"no recovery weights for {models} in {wdir}")

    def repair_fn(net: TorchBackend, scale: float) -> object:
        def fn(x: np.ndarray, prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
            pred, mask = net.recover(x[None], None if prev is None else prev[None])
            units = to_depth_units(np.rint(x * scale).astype(np.uint16), pred[0], mask[0], scale)
            return units.astype(np.float32) / np.float32(scale), mask[0]

        return fn

    sets = ([l515_set(real)] if (real / "dev0").is_dir() else []) + [generated_set(cache), moving_set()]
    tables: dict[str, dict] = {}
    curves: dict[str, dict] = {}
    first = next(iter(nets))

    logits = sorted({*CURVE_LOGITS, nets[first].mask_logit}, reverse=True)  # the model's own on the curve

    def raw(x: np.ndarray, prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        logit, pred = nets[first].raw(x[None], None if prev is None else prev[None])
        return logit[0], pred[0]

    with out_dir(out, overwrite, [real]) as tmp:
        with progress_bar() as bar:
            for ts in sets:
                fns = {k: repair_fn(v, ts.scale) for k, v in nets.items()}
                n = int(ts.labels.sum()) if not limit else min(limit, int(ts.labels.sum()))
                task = bar.add_task(f"recovery on {ts.name}", total=n)
                rows, errors = recovery_metrics(ts, fns, first, n, lambda task=task: bar.advance(task))  # type: ignore[misc]
                tables[ts.name] = rows
                curves[ts.name] = operating_curve(ts, raw, logits, n)
                keep = [
                    "identity",
                    *fns,
                    *(f"{b} (predicted mask)" for b in ("median", "nearest", "ip-basic", "inpaint")),
                ]
                save(
                    error_cdf({k: errors[k] for k in keep if k in errors}, f"Per-pixel error, {ts.name}"),
                    tmp / f"error_cdf_{ts.name}.png",
                )
                idx = [i for i in np.flatnonzero(ts.labels)][:: max(1, int(ts.labels.sum()) // 4)][:4]
                rows_g = []
                for i in idx:
                    x = ts.metres(i)
                    y = ts.clean[i].astype(np.float32) / np.float32(ts.scale)
                    o, m = fns[first](x, ts.previous(int(i)))
                    rows_g.append((f"{ts.name} #{i}", x, ts.frames[i] != ts.clean[i], m, o, y))
                save(gallery(rows_g), tmp / f"gallery_{ts.name}.png")
        save(operating_curves(curves, nets[first].mask_logit, first), tmp / "operating_curve.png")
        (tmp / "recovery.json").write_text(
            json.dumps(tables | {"operating_curve": {first: curves}}, indent=1) + "\n"
        )
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
                    f"| {r['mask_precision']:.3f} | "
                    f"{r['mask_recall']:.3f} | {r['mask_f1']:.3f} | {100 * r['clean_changed']:.2f}% |"
                )
            lines.append("")
        lines += [f"Mask threshold trade-off of {first}: [operating_curve.png](operating_curve.png)", ""]
        (tmp / "table.md").write_text("\n".join(lines))
    console.print("\n".join(lines))
    if card:
        for name in nets:
            write_card(
                wdir / f"{name}.safetensors",
                evaluation=f"d2sr eval recovery --models {name} --limit {limit}",
                metrics={
                    f"{SET_TITLES[s]}: RMSE cm (vs identity) / mask F1 / clean px changed": (
                        f"{t[name]['rmse_cm']:.2f} ({100 * t[name]['rmse_vs_identity']:+.1f}%) / "
                        f"{t[name]['mask_f1']:.3f} / "
                        f"{100 * t[name]['clean_changed']:.2f}%"
                    )
                    for s, t in tables.items()
                },
            )


def eval_paper(
    out: Annotated[Path, typer.Option(help="Folder for report.md, results.json and plots.")] = Path(
        "docs/results/paper"
    ),
    weights: Weights = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    rooms: Annotated[int, typer.Option(help="Rooms per Fig. 9 cell.")] = 4,
    limit: Annotated[int, typer.Option(help="Interfered frames per recovery test set.")] = 60,
    overwrite: Overwrite = False,
) -> None:
    """The paper's evaluation in one report: Fig. 3, Fig. 9, detector P/R/F1, Tables I-II, Fig. 10, Table
    III (latency here), side by side with the paper's numbers."""
    import json

    from d2sr.bench import bench_models
    from d2sr.eval import paper

    if rooms < 2 or limit < 1:
        raise ConfigError("need --rooms >= 2 and --limit >= 1")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    command = f"d2sr eval paper --out {out} --rooms {rooms} --limit {limit}"

    def step(name: str, fn: object) -> object:
        with console.status(name):
            return fn()  # type: ignore[operator]

    with out_dir(out, overwrite, [real]) as tmp:
        res = paper.run_all(tmp, step, rooms)
        eval_detector(out=tmp / "detector", weights=weights, real=real, cache=cache, card=False)
        eval_recovery(out=tmp / "recovery", weights=weights, real=real, cache=cache, limit=limit, card=False)
        bench = step(
            "Table III: latency",
            lambda: bench_models(("unet8", "unet16", "unet32"), repeats=20, outside=False),
        )
        detector = json.loads((tmp / "detector" / "detector.json").read_text())
        recovery = json.loads((tmp / "recovery" / "recovery.json").read_text())
        latency = paper.latency_ms(bench)  # type: ignore[arg-type]
        text = paper.markdown(res, detector, recovery, latency, command)
        (tmp / "report.md").write_text(text)
        paper.dump(tmp / "results.json", res | {"latency_ms": latency})
    console.print(f"Report: {out / 'report.md'}")
