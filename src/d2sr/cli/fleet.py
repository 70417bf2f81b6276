"""``d2sr fleet``: options parsed here, the work done by ``d2sr.fleet.recover_fleet`` on Ray."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table
from rich.text import Text

from d2sr.cli.common import (
    BackendOpt,
    MaskLogit,
    MaxRange,
    ModelDir,
    ModelName,
    Overwrite,
    Passes,
    PrimeOpt,
    RecoverRepairOpt,
    Scale,
    ScaleWrong,
    SceneFromOpt,
    SceneOpt,
    SceneRepairOpt,
    Threshold,
    Topic,
    repair_of,
)
from d2sr.contract.catalog import DEFAULT_MODEL, WEIGHTS
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.jobs.recordings import Written
from d2sr.runtime.settings import PRIME_FRAMES, RunSettings
from d2sr.ui import console, print_line, progress_bar

__all__ = ["fleet"]


def fleet(
    recordings: Annotated[
        list[Path],
        typer.Argument(
            help="Recordings, any that d2sr recover reads (PNG folders, npz, bags).", metavar="REC..."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            help="Output folder: OUT/<name> per recording, as d2sr recover writes it, and OUT/fleet.json."
        ),
    ],
    workers: Annotated[
        int | None,
        typer.Option(help="Recordings repaired at once, one core each (default: every core of the cluster)."),
    ] = None,
    address: Annotated[
        str | None,
        typer.Option(
            help="HOST:PORT of a running Ray cluster's head node (started with ray start), or auto; "
            "default: a local cluster started for this run."
        ),
    ] = None,
    depth_scale: Scale = None,
    recording_scale_wrong: ScaleWrong = False,
    repair: RecoverRepairOpt = "flagged",
    model: ModelName = DEFAULT_MODEL,
    threshold: Threshold = None,
    mask_logit: MaskLogit = None,
    passes: Passes = None,
    topic: Topic = None,
    format: Annotated[str, typer.Option(help="auto, png or bag, as d2sr recover's --format.")] = "auto",
    backend: BackendOpt = "auto",
    models: ModelDir = WEIGHTS,
    max_range: MaxRange = PLAUSIBLE_M[1],
    scene: SceneOpt = True,
    scene_from: SceneFromOpt = None,
    scene_repair: SceneRepairOpt = None,
    prime: PrimeOpt = PRIME_FRAMES,
    report: Annotated[
        bool, typer.Option("--report/--no-report", help="Each recording's report.html, as d2sr recover's.")
    ] = True,
    overwrite: Overwrite = False,
) -> None:
    """Repair many recordings on Ray, each exactly as d2sr recover would. Run again, it skips the
    recordings done and redoes the rest; a broken recording does not stop the others (each failure is named
    at the end, exit 1). Needs the fleet extra (Ray).

    Example: d2sr fleet robots/*/depth/ --out repaired/ --workers 2
    """
    from d2sr.fleet import Cluster, FleetProgress, recover_fleet
    from d2sr.fleet.ledger import printable

    settings = RunSettings(
        recording_scale_wrong=recording_scale_wrong,
        depth_scale=depth_scale, topic=topic, repair=repair_of(repair), model=model,
        models=models, threshold=threshold, mask_logit=mask_logit, passes=passes, backend=backend,
        max_range=max_range, scene=scene, scene_repair=scene_repair, prime=prime, scene_from=scene_from,
    )  # fmt: skip
    written = Written(format, None, None, overwrite, report)
    with progress_bar() as bar:
        task = bar.add_task("fleet", total=None)

        def show(p: FleetProgress) -> None:
            what = f"fleet: {p.done} done, {p.failed} failed, {p.remaining} to go"
            bar.update(task, description=what, completed=p.frames, total=max(p.total, 1))

        s = recover_fleet(
            recordings, out, settings, written, cluster=Cluster(workers, address), progress=show
        )
    table = Table("recording", "frames", "flagged", "changed", "pixels", "seconds", "status")
    for o in s.outcomes:
        row = (o.frames, o.flagged, o.changed, f"{o.pixels:,}", f"{o.seconds:.1f}")
        table.add_row(Text(printable(o.name)), *map(str, row), o.status)  # names are data, not markup
    console.print(table)
    done = [o for o in s.outcomes if o.status == "done"]
    before = f" ({s.skipped} as a run before left them, not redone)" if s.skipped else ""
    flagged, changed = sum(o.flagged for o in done), sum(o.changed for o in done)
    pixels = sum(o.pixels for o in done)
    print_line(f"{len(done)} of {len(s.outcomes)} recordings done{before}: {flagged} frames flagged, "
               f"{changed} changed ({pixels:,} pixels); {s.frames} frames read this run in {s.seconds:.1f} s "
               f"-> {s.out}")  # fmt: skip
    for o in s.outcomes:
        for w in o.warnings:
            print(w if w.startswith("d2sr: ") else f"d2sr: warning: {w}", file=sys.stderr)
    for o in s.failed:
        print(f"d2sr: error: {printable(o.input)}: {o.reason}", file=sys.stderr)
    if s.failed:
        raise typer.Exit(1)
