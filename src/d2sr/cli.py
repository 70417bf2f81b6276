"""The ``d2sr`` command line (typer). Every D2SRError becomes one line on stderr and exit code 2."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from d2sr import __version__
from d2sr.errors import ConfigError, D2SRError

app = typer.Typer(help="d2sr: keep depth sensors working when several share a room.", no_args_is_help=True)
desync_app = typer.Typer(help="Stage 2: decentralized de-synchronization experiments.", no_args_is_help=True)
app.add_typer(desync_app, name="desync")
console = Console()


def _version(value: bool) -> None:
    if value:
        console.print(f"d2sr {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """d2sr: decentralized detection, de-synchronization and recovery of depth-sensor interference."""


def _progress() -> Progress:
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
    )


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def _split(value: str, what: str, choices: tuple[str, ...] | None = None) -> list[str]:
    items = [v.strip() for v in value.split(",") if v.strip()]
    if not items:
        raise ConfigError(f"--{what} is empty")
    if choices:
        bad = [v for v in items if v not in choices]
        if bad:
            raise ConfigError(f"--{what}: unknown {', '.join(bad)}; choose from {', '.join(choices)}")
    return items


def _ints(value: str, what: str) -> list[int]:
    try:
        return [int(v) for v in _split(value, what)]
    except ValueError:
        raise ConfigError(f"--{what} takes comma-separated integers, got {value!r}") from None


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for the plots.")] = Path("out/demo"),
    sensors: Annotated[int, typer.Option(help="Sensors sharing one room.")] = 3,
    fps: Annotated[int, typer.Option(help="Active frames per 1 s period (30 = always on).")] = 6,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 30.0,
    rooms: Annotated[int, typer.Option(help="Independent rooms averaged.")] = 20,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Simulate sensors sharing a room under each controller; print a table and write plots."""
    from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
    from d2sr.eval.desync import convergence_periods
    from d2sr.eval.plots import ratio_over_time, save, sensor_timeline
    from d2sr.sim import OverlapGraph, TimingConfig, simulate

    if sensors < 1 or rooms < 1:
        raise ConfigError("--sensors and --rooms must be at least 1")
    cfg = TimingConfig.make(active_frames=fps)
    graph = OverlapGraph.complete(sensors).replicate(rooms)
    names = ["static", "d2sr", DEFAULT_CONTROLLER, "oracle"]
    assert all(n in CONTROLLERS for n in names)
    table = Table(
        title=f"{sensors} sensors in one room, {fps} of 30 frames per second, {seconds:g} s, {rooms} rooms"
    )
    for col in (
        "controller",
        "interfered (whole run)",
        "interfered (2nd half)",
        "median convergence",
        "vs static",
    ):
        table.add_column(col, justify="right" if col != "controller" else "left")
    series, base = {}, None
    written = []
    with _progress() as bar:
        task = bar.add_task("simulating", total=len(names))
        for name in names:
            run = simulate(graph, name, cfg, seconds, seed=seed, record_frames=True)
            _, per_room = run.group_ratios()
            series[name] = per_room.mean(axis=0)
            whole, steady = run.ratio(), run.ratio(start=run.periods // 2)
            base = whole if name == "static" else base
            conv = convergence_periods(per_room)
            med = float(np.median(conv))
            label = name + (" (ours, default)" if name == DEFAULT_CONTROLLER else "")
            label += " (paper Alg. 1)" if name == "d2sr" else ""
            label += " (global knowledge)" if name == "oracle" else ""
            table.add_row(
                label,
                f"{whole:.1%}",
                f"{steady:.1%}",
                "never" if med == float("inf") else f"{med:.0f} periods",
                "" if name == "static" or not base else f"-{1 - whole / base:.0%}",
            )
            periods = min(run.periods, 30)
            written.append(
                save(
                    sensor_timeline(
                        run, list(range(sensors)), periods, f"{name}: room 0, each sensor's slots over time"
                    ),
                    out / f"timeline_{name}.png",
                )
            )
            bar.advance(task)
    written.append(
        save(
            ratio_over_time(series, DEFAULT_CONTROLLER, f"mean over {rooms} rooms"),
            out / "ratio_over_time.png",
        )
    )
    console.print(table)
    console.print("Plots: " + ", ".join(str(p) for p in written))


@desync_app.command("sweep")
def desync_sweep(
    out: Annotated[Path, typer.Option(help="Folder for CSV, JSON, plots and summary.")] = Path(
        "docs/results/desync"
    ),
    replicas: Annotated[int, typer.Option(help="Independent rooms per cell.")] = 20,
    duration: Annotated[float, typer.Option(help="Simulated seconds per run.")] = 60.0,
    fps: Annotated[str, typer.Option(help="Frame rates, comma-separated.")] = "6,10,15,20,25,30",
    sensors: Annotated[str, typer.Option(help="Sensor counts, comma-separated.")] = "1,2,3,4,5",
    controllers: Annotated[str, typer.Option(help="Controllers, comma-separated.")] = "",
    scenarios: Annotated[str, typer.Option(help="stationary,moving")] = "stationary,moving",
    profiles: Annotated[str, typer.Option(help="Noise profiles: default,harsh.")] = "default,harsh",
    jobs: Annotated[int, typer.Option(help="Worker processes (0 = all cores).")] = 0,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Interference ratio against frame rate and N for every controller (paper Fig. 9 and ours)."""
    from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
    from d2sr.eval import desync as ev
    from d2sr.eval import plots

    ctrl = _split(controllers, "controllers", tuple(CONTROLLERS)) if controllers else list(ev.CONTROLLERS)
    prof = _split(profiles, "profiles", tuple(ev.PROFILES))
    scen = _split(scenarios, "scenarios", ev.SCENARIOS)
    fps_l, n_l = _ints(fps, "fps"), _ints(sensors, "sensors")
    if replicas < 2 or duration <= 0 or any(f < 1 or f > 30 for f in fps_l) or any(n < 1 for n in n_l):
        raise ConfigError("need replicas >= 2, duration > 0, fps in 1..30 and sensors >= 1")
    grid = ev.cells(scen, fps_l, n_l, ctrl, ["default"], replicas, duration, seed)
    if "harsh" in prof:  # robustness: only the default and Algorithm 1 are rerun
        grid += ev.cells(
            scen,
            fps_l,
            n_l,
            [c for c in ctrl if c in ("d2sr", DEFAULT_CONTROLLER)],
            ["harsh"],
            replicas,
            duration,
            seed,
        )
    with _progress() as bar:
        task = bar.add_task("cells", total=len(grid))
        results = ev.sweep(grid, jobs or None, progress=lambda _: bar.advance(task))
    order = {c: i for i, c in enumerate(ctrl)}
    results.sort(key=lambda r: (r.profile, r.scenario, r.fps, r.sensors, order.get(r.controller, 99)))
    out.mkdir(parents=True, exist_ok=True)
    ev.write_csv(results, out / "sweep.csv")
    checks = ev.check_bars(results, DEFAULT_CONTROLLER)
    head = ev.headline(results, DEFAULT_CONTROLLER)
    command = "d2sr desync sweep " + " ".join(sys.argv[3:])
    summary = {
        "command": command.strip(),
        "headline_reduction_N2_15fps": head,
        "bars": checks,
        "bars_failed": [c for c in checks if not c["ok"]],
    }
    _atomic_write(out / "sweep.json", ev.to_json(results))
    _atomic_write(out / "summary.json", json.dumps(summary, indent=1, default=float))
    for p in prof:
        plots.save(plots.fig9(results, DEFAULT_CONTROLLER, p), out / f"fig9_{p}.png")
        plots.save(plots.paired(results, DEFAULT_CONTROLLER, p), out / f"paired_{p}.png")
    plots.save(plots.convergence_cdf(results, DEFAULT_CONTROLLER), out / "convergence.png")
    failed = summary["bars_failed"]
    console.print(
        f"{len(results)} cells; bars: {len(checks) - len(failed)}/{len(checks)} pass; "
        f"headline (N=2, 15 fps, reduction vs static): " + ", ".join(f"{k} {v:.1%}" for k, v in head.items())
    )
    for c in failed:
        ref = c.get("reference", float("nan"))
        console.print(f"  [red]fails[/red] {c['bar']}: {c['cell']} value={c['value']:.3f} ref={ref:.3f}")
    console.print(f"Wrote {out}/sweep.csv, sweep.json, summary.json and PNG plots")


@app.command()
def bench(
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results to this JSON file.")] = None,
    sensors: Annotated[int, typer.Option(help="Sensors in the timing-world benchmark.")] = 1000,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 600.0,
    repeats: Annotated[int, typer.Option(help="Repeats (median reported).")] = 3,
) -> None:
    """Benchmarks: the timing world at warehouse scale (later: each learned stage)."""
    from d2sr.bench import bench_timing

    if sensors < 1 or seconds <= 0 or repeats < 1:
        raise ConfigError("need sensors >= 1, seconds > 0 and repeats >= 1")
    result = bench_timing(sensors, seconds, repeats)
    console.print_json(json.dumps(result))
    if json_out:
        _atomic_write(json_out, json.dumps(result, indent=1) + "\n")


def main() -> None:
    """Console entry point: one-line errors with exit code 2 instead of tracebacks."""
    try:
        app()
    except D2SRError as exc:
        print(f"d2sr: error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
