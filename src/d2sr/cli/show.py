"""``d2sr demo`` (the closed loop in a simulated room, with a report), ``d2sr view`` (a finished run in
Rerun) and ``d2sr gallery`` (the simulated interference kinds)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer
from rich import box
from rich.table import Table

from d2sr.atomic import check_out
from d2sr.cli.common import BackendOpt, Overwrite
from d2sr.contract.catalog import DEFAULT_MODEL
from d2sr.errors import ConfigError
from d2sr.ui import console, progress_bar

__all__ = ["demo", "gallery", "view"]


def demo(
    out: Annotated[Path, typer.Option(help="Folder for the runs, plots and report.")],
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 20.0,
    backend: BackendOpt = "auto",
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """The closed loop: 3 simulated L515s in one room under static, d2sr and the default controller, with
    the shipped models; a table, and a report with plots.

    Example: d2sr demo --out out/demo
    """
    from d2sr.eval.demo import CAPTION, DEMO_CONTROLLERS, HEADERS, run_demo, table_rows
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.settings import RunSettings

    if not seconds > 0:
        raise ConfigError(f"--seconds must be positive, got {seconds}")
    check_out(out, is_dir=True, overwrite=overwrite)
    net = open_backend(RunSettings(model=DEFAULT_MODEL, backend=backend))
    t = time.perf_counter()
    with progress_bar() as bar:
        tasks = {c: bar.add_task(f"{c:8s} 3 sensors, {seconds:g} s", total=1.0) for c in DEMO_CONTROLLERS}
        report = run_demo(
            net, out, seconds, seed=seed, progress=lambda c, f: bar.update(tasks[c], completed=f)
        )
    table = Table(
        title=f"3 simulated L515s, 6 of 30 frames per second, {seconds:g} s, closed loop ({net.name})",
        caption=CAPTION,
        caption_justify="left",
        box=box.SIMPLE_HEAD,
        collapse_padding=True,
        pad_edge=False,
    )
    for h in HEADERS:
        table.add_column(h, justify="left" if h == "controller" else "right", no_wrap=True)
    for row in table_rows(report):
        table.add_row(*row)
    console.print(table)
    console.print(f"Report: {out / 'report.md'} ({time.perf_counter() - t:.0f} s)")


def view(
    run: Annotated[
        Path, typer.Argument(help="A finished d2sr run folder (holds log.csv).", metavar="RUN_DIR")
    ],
    save: Annotated[
        Path | None, typer.Option(help="Save a FILE.rrd instead of opening a viewer.", metavar="FILE.rrd")
    ] = None,
    overwrite: Annotated[
        bool,
        typer.Option(
            "--overwrite",
            metavar="",
            help="Replace a FILE.rrd that d2sr wrote (never a file it did not make).",
        ),
    ] = False,
) -> None:
    """Open a finished run in Rerun: every sensor's repaired frames and predicted masks, and the detector
    score, flag and window over time. Example: d2sr view out/demo/runs/robust"""
    from d2sr.jobs.viewer import LIVE
    from d2sr.jobs.viewer import view as replay

    if save is not None:
        check_out(save, is_dir=False, overwrite=overwrite, inputs=[run], name="save")
    n = replay(run, save if save is not None else LIVE)
    console.print(f"{n} frames of {run} -> {save or 'the Rerun viewer'}")


def gallery(
    out: Annotated[Path, typer.Option(help="PNG file to write.")],
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """A gallery of simulated frames: each interference kind, clean / interfered / true mask.

    Example: d2sr gallery --out out/gallery.png
    """
    from d2sr.eval.plots import save
    from d2sr.eval.sim_gallery import gallery_figure

    check_out(out, is_dir=False, overwrite=overwrite)
    save(gallery_figure(seed), out)
    console.print(f"Wrote {out}")
