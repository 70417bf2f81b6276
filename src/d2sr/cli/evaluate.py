"""``d2sr eval detector|recovery|paper|labels``: held-out evaluations that write JSON, tables and plots."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, TypeVar

import typer
from rich.progress import Progress
from rich.table import Table

from d2sr.atomic import check_out
from d2sr.cli.common import BackendOpt, Cache, ModelDir, Overwrite, Real, out_dir, split_list
from d2sr.contract.catalog import DEFAULT_RECOVERY, MODEL_HELP, THRESHOLD, WEIGHTS, check_probability
from d2sr.errors import ConfigError, InputError
from d2sr.provenance import stamp
from d2sr.sim.families import FAMILIES
from d2sr.ui import console, progress_bar

__all__ = ["detector", "generalization", "labels", "paper", "recovery"]

T = TypeVar("T")
DATA = Path("../shared/data")
REAL = DATA / "l515"
CACHE = Path("out/data")


def _steps(bar: Progress) -> Callable[[str, int], Callable[[], None]]:
    def open_task(description: str, total: int) -> Callable[[], None]:
        task = bar.add_task(description, total=total)
        return lambda: bar.advance(task)

    return open_task


def detector(
    out: Annotated[Path, typer.Option(help="Folder for detector.json and pr.png.")],
    model: Annotated[
        str, typer.Option(help="Detectors (comma-separated names).")
    ] = "detector,paper-detector",
    models: ModelDir = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    threshold: Annotated[float, typer.Option(help="Detector probability that flags a frame.")] = THRESHOLD,
    overwrite: Overwrite = False,
) -> None:
    """Detector precision/recall on the generated test set and on real L515 frames with simulated
    interference; PR curves.

    Example: d2sr eval detector --real ../shared/data/l515 --out out/eval/detector
    """
    from d2sr.eval.learned import evaluate_detectors, write_detectors

    check_probability(threshold, "--threshold")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    with progress_bar() as bar:
        results = evaluate_detectors(split_list(model, "model"), models, real, cache, threshold, _steps(bar))
    if not results:
        raise ConfigError(f"no detector weights for {model} in {models}")
    with out_dir(out, overwrite, [real]) as tmp:
        write_detectors(results, tmp, models)
    for k, r in results.items():
        extra = f", people {r['false_alarm_rate_people']:.3f}" if "false_alarm_rate_people" in r else ""
        console.print(
            f"{k}: precision {r['precision']:.4f} recall {r['recall']:.4f} f1 {r['f1']:.4f} "
            f"false alarms {r['false_alarm_rate']:.4f}{extra} ({r['frames']} frames)"
        )


def recovery(
    out: Annotated[Path, typer.Option(help="Folder for recovery.json, tables and plots.")],
    model: Annotated[
        str, typer.Option(help="Recovery models (comma-separated names).")
    ] = "unet8,unet16,unet32,unet8-temporal,unet8-fast",
    models: ModelDir = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    limit: Annotated[int, typer.Option(help="Interfered frames per test set (0: all).")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """Recovery on interfered frames: RMSE, mask F1, clean pixels changed; baselines; error CDF; gallery.

    Example: d2sr eval recovery --real ../shared/data/l515 --limit 60 --out out/eval/recovery
    """
    from d2sr.eval.learned import evaluate_recovery

    if limit < 0:
        raise ConfigError(f"--limit must be >= 0, got {limit}")
    names = split_list(model, "model")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    with out_dir(out, overwrite, [real]) as tmp, progress_bar() as bar:
        result = evaluate_recovery(names, models, real, cache, limit, tmp, _steps(bar))
    console.print(result["table"])


def paper(
    out: Annotated[Path, typer.Option(help="Folder for report.md, results.json and plots.")],
    models: ModelDir = WEIGHTS,
    real: Real = REAL,
    cache: Cache = CACHE,
    rooms: Annotated[int, typer.Option(help="Rooms per Fig. 9 cell.")] = 4,
    limit: Annotated[int, typer.Option(help="Interfered frames per recovery test set.")] = 60,
    overwrite: Overwrite = False,
) -> None:
    """The paper's evaluation in one report: Fig. 3, Fig. 9 (and a robot passing a ring), Fig. 11
    (synthesized frames: RMSE and coverage), detector P/R/F1, Tables I-II, Fig. 10, Table III (latency
    here), side by side with the paper's numbers.

    Example: d2sr eval paper --real ../shared/data/l515 --out out/eval/paper
    """
    from d2sr.eval.paper import report

    if rooms < 2 or limit < 1:
        raise ConfigError("need --rooms >= 2 and --limit >= 1")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    command = f"d2sr eval paper --out {out} --rooms {rooms} --limit {limit}"

    def step(name: str, fn: Callable[[], T]) -> T:
        with console.status(name):
            return fn()

    with out_dir(out, overwrite, [real]) as tmp:
        report(tmp, models, real, cache, rooms, limit, command, step)
    console.print(f"Report: {out / 'report.md'}")


def labels(
    out: Annotated[Path, typer.Option(help="Folder for labels.json and labels.png.")],
    real: Annotated[
        Path | None, typer.Option(help="Folder holding the L515 captures dev0/ and dev1/.")
    ] = None,
    sims: Annotated[int, typer.Option(help="Simulated static rooms.")] = 4,
    overwrite: Overwrite = False,
) -> None:
    """Mask F1 of the labelling methods on simulated static sequences and on real captures with simulated
    interference (per threshold for the paper's method).

    Example: d2sr eval labels --real ../shared/data/l515 --out out/eval/labels
    """
    from d2sr.eval.labels import run_all
    from d2sr.eval.plots import label_f1, save

    if sims < 0:
        raise ConfigError("--sims must be >= 0")
    if real is not None and not real.is_dir():
        raise InputError(f"{real}: not a folder")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[real])
    with progress_bar() as bar:
        task = bar.add_task("cases", total=sims + (2 if real else 0))
        results = run_all(real, sims, progress=lambda _: bar.advance(task))
    if not results:
        raise ConfigError("nothing to evaluate: give --real or --sims > 0")
    t = Table("case", *next(iter(results.values())).keys())
    for case, row in results.items():
        t.add_row(case, *(f"{v['f1']:.3f}" for v in row.values()))
    console.print(t)
    with out_dir(out, overwrite, [real]) as tmp:
        (tmp / "labels.json").write_text(json.dumps(stamp({"results": results}), indent=1) + "\n")
        save(label_f1(results), tmp / "labels.png")
    console.print(f"Wrote {out}/labels.json and labels.png")


def generalization(
    out: Annotated[Path, typer.Option(help="Folder for generalization.json, README.md and the plot.")],
    data: Annotated[Path, typer.Option(help="The shared real data folder (l515/, d435/, ...).")] = DATA,
    model: Annotated[str, typer.Option(help=MODEL_HELP)] = DEFAULT_RECOVERY,
    models: ModelDir = WEIGHTS,
    backend: BackendOpt = "auto",
    lofo: Annotated[
        Path | None,
        typer.Option(help="Folder of detectors trained without one family each: no-<family>/detector.*"),
    ] = None,
    lofo_recovery: Annotated[
        Path | None,
        typer.Option(
            help="Folder of recovery models trained without one family each (no-<family>/<model>.*) "
            "and the same recipe on every family (all/<model>.*)"
        ),
    ] = None,
    overwrite: Overwrite = False,
) -> None:
    """False alarms on every real clean frame of every sensor, and each interference family alone on real
    L515 frames (with --lofo / --lofo-recovery: by models trained without it). Worst cells beside the means.

    Example: d2sr eval generalization --data ../shared/data --lofo runs/lofo
    --lofo-recovery runs/lofo-recovery --out out/eval/generalization
    """
    from d2sr.eval import generalization as g
    from d2sr.eval.model_plots import generalization as plot
    from d2sr.eval.plots import save
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.settings import RunSettings

    if not data.is_dir():
        raise InputError(f"{data}: not a folder")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[data])
    net = open_backend(RunSettings(model=model, backend=backend, models=models))

    def finished(root: Path | None, names: tuple[str, ...], name: str) -> dict[str, Path]:
        folders = {n: root / (n if n == "all" else f"no-{n}") for n in names} if root else {}
        return {n: f for n, f in folders.items() if (f / f"{name}.safetensors").is_file()}  # finished runs

    left = {
        k: open_backend(RunSettings(backend=backend, models=f), recovery=False)
        for k, f in finished(lofo, FAMILIES, "detector").items()
    }
    left_rec = {
        k: open_backend(RunSettings(model=model, backend=backend, models=f), detector=False)
        for k, f in finished(lofo_recovery, ("all", *FAMILIES), model).items()
    }
    sets = g.real_clean_sets(data)
    l515 = sum(len(s.frames) for s in sets if s.name.startswith("L515"))
    with progress_bar() as bar:
        task = bar.add_task("real clean frames", total=sum(len(s.frames) for s in sets))
        real = g.real_rows(net, sets, lambda: bar.advance(task))
        task = bar.add_task("interference families", total=l515 * len(FAMILIES))
        fams = g.family_rows(net, sets, left, tick=lambda: bar.advance(task), lofo_recovery=left_rec)
    worst = g.summary(real, fams)
    md = g.table(real, fams, worst)
    result = stamp({"model": model, "real": real, "families": fams, "worst": worst}, models=[model])
    with out_dir(out, overwrite, [data]) as tmp:
        (tmp / "generalization.json").write_text(json.dumps(result, indent=1) + "\n")
        (tmp / "README.md").write_text(f"# Generalization\n\n`{result['command']}`\n\n{md}")
        save(plot(real, fams), tmp / "generalization.png")
    console.print(md)
