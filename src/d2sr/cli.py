"""The ``d2sr`` command line (typer). Every D2SRError becomes one line on stderr and exit code 2."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from d2sr import __version__, cli_data, cli_models, cli_run, cli_train
from d2sr.atomic import atomic_write, check_out
from d2sr.cli_common import Overwrite, int_list, out_dir, split_list
from d2sr.config import load_toml
from d2sr.errors import ConfigError, D2SRError
from d2sr.sim.timing import TimingConfig
from d2sr.ui import console, flush_warnings, progress_bar

app = typer.Typer(help="d2sr: keep depth sensors working when several share a room.", no_args_is_help=True)
desync_app = typer.Typer(help="Stage 2: decentralized de-synchronization experiments.", no_args_is_help=True)
app.add_typer(desync_app, name="desync")
eval_app = typer.Typer(help="Evaluations that write JSON and plots.", no_args_is_help=True)
app.add_typer(eval_app, name="eval")
app.command("simulate")(cli_data.simulate)
app.command("label")(cli_data.label)
app.command("calibrate")(cli_data.calibrate)
app.command("gallery")(cli_data.gallery)
eval_app.command("labels")(cli_data.eval_labels)
app.command("detect")(cli_models.detect)
app.command("recover")(cli_models.recover)
app.command("run")(cli_run.run)
app.command("train")(cli_train.train)
app.command("export")(cli_train.export)
eval_app.command("detector")(cli_train.eval_detector)
eval_app.command("recovery")(cli_train.eval_recovery)
eval_app.command("paper")(cli_train.eval_paper)


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


def _compare(
    out: Path,
    scenario: str,
    sensors: int,
    fps: int,
    seconds: float,
    rooms: int,
    controllers: list[str],
    config: TimingConfig,
    seed: int,
    json_out: Path | None = None,
    overwrite: bool = False,
) -> None:
    """Run each controller on the same rooms; print a table, write timelines and the ratio over time."""
    from d2sr.desync import DEFAULT_CONTROLLER
    from d2sr.eval.desync import Cell, simulate_cell, summarize
    from d2sr.eval.plots import ratio_over_time, save, sensor_timeline

    if sensors < 1 or rooms < 2:
        raise ConfigError("need --sensors >= 1 and --rooms >= 2")
    check_out(out, is_dir=True, overwrite=overwrite)
    if json_out:
        check_out(json_out, is_dir=False, overwrite=overwrite)
    where = "a robot among fixed sensors" if scenario == "moving" else "one room"
    table = Table(
        title=f"{sensors} sensors in {where}, {fps} of {config.total_frames} frames per second, "
        f"{seconds:g} s, {rooms} rooms"
    )
    for col in (
        "controller",
        "interfered (whole run)",
        "interfered (2nd half)",
        "median convergence",
        "vs static",
    ):
        table.add_column(col, justify="left" if col == "controller" else "right")
    series, rows, written = {}, [], []
    base = None
    with out_dir(out, overwrite) as tmp, progress_bar() as bar:
        task = bar.add_task("simulating", total=len(controllers))
        for name in controllers:
            cell = Cell(scenario, fps, sensors, name, replicas=rooms, duration_s=seconds, seed=seed)
            cfg, graph, run = simulate_cell(cell, config, record_frames=True)
            result, ratios = summarize(cell, cfg, graph, run)
            series[name] = ratios.mean(axis=0)
            base = result.whole if name == "static" else base
            rows.append(result)
            note = {
                "d2sr": " (paper Alg. 1)",
                "oracle": " (global knowledge)",
                DEFAULT_CONTROLLER: " (ours, default)",
            }
            med = result.converged_median
            table.add_row(
                name + note.get(name, ""),
                f"{result.whole:.1%} ± {result.whole_ci:.1%}",
                f"{result.steady:.1%}",
                "never" if not np.isfinite(med) else f"{med:.0f} periods",
                f"-{1 - result.whole / base:.0%}" if base and name != "static" else "",
            )
            shown = list(range(min(sensors, 5)))
            title = f"{name}: room 0, each sensor's slots over time" + (
                " (sensor 0 = robot)" if scenario == "moving" else ""
            )
            written.append(
                save(
                    sensor_timeline(run.frames, config.total_frames, shown, min(run.periods, 30), title),
                    tmp / f"timeline_{name}.png",
                )
            )
            bar.advance(task)
        written.append(
            save(
                ratio_over_time(series, DEFAULT_CONTROLLER, f"mean over {rooms} rooms"),
                tmp / "ratio_over_time.png",
            )
        )
    written = [out / p.name for p in written]
    console.print(table)
    if scenario == "moving":
        console.print("Moving robot: the ratios count the robot's frames only (as in the paper).")
    console.print("Plots: " + ", ".join(str(p) for p in written))
    if json_out:
        from d2sr.eval.desync import to_json

        atomic_write(json_out, to_json(rows))
        console.print(f"Results: {json_out}")


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for the runs, plots and report.")] = Path("out/demo"),
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 20.0,
    backend: Annotated[str, typer.Option(help="auto (onnxruntime when installed), onnx or torch.")] = "auto",
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """The closed loop: 3 simulated L515s in one room under static, d2sr and the default controller, with
    the shipped models; a table, and a report with plots."""
    from d2sr.eval.demo import CONTROLLERS, HEADERS, run_demo, table_rows
    from d2sr.runtime.backends import open_backend

    if not seconds > 0:
        raise ConfigError(f"--seconds must be positive, got {seconds}")
    check_out(out, is_dir=True, overwrite=overwrite)
    net = open_backend("unet8", backend)
    t = time.perf_counter()
    with progress_bar() as bar:
        tasks = {c: bar.add_task(f"{c:8s} 3 sensors, {seconds:g} s", total=1.0) for c in CONTROLLERS}
        report = run_demo(
            net, out, seconds, seed=seed, progress=lambda c, f: bar.update(tasks[c], completed=f)
        )
    table = Table(
        title=f"3 simulated L515s, 6 of 30 frames per second, {seconds:g} s, closed loop ({net.name})"
    )
    for h in HEADERS:
        table.add_column(h, justify="left" if h == "controller" else "right")
    for row in table_rows(report):
        table.add_row(*row)
    console.print(table)
    console.print(f"Report: {out / 'report.md'} ({time.perf_counter() - t:.0f} s)")


@desync_app.command("run")
def desync_run(
    out: Annotated[Path, typer.Option(help="Folder for the plots.")] = Path("out/desync"),
    scenario: Annotated[
        str, typer.Option(help="stationary (everyone overlaps) or moving (a robot).")
    ] = "stationary",
    sensors: Annotated[int, typer.Option(help="Sensors (moving: the robot plus N-1 fixed ones).")] = 3,
    fps: Annotated[int, typer.Option(help="Active frames per period (total_frames = always on).")] = 6,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 60.0,
    rooms: Annotated[int, typer.Option(help="Independent rooms averaged.")] = 20,
    controllers: Annotated[str, typer.Option(help="Comma-separated; default: all.")] = "",
    config: Annotated[
        Path | None, typer.Option(help="TOML with timing-world settings (TimingConfig).")
    ] = None,
    recall: Annotated[float | None, typer.Option(help="Detector recall.")] = None,
    false_alarm: Annotated[float | None, typer.Option(help="Detector false-alarm rate.")] = None,
    hit_prob: Annotated[float | None, typer.Option(help="P(frame corrupted | overlapped).")] = None,
    drift_ppm: Annotated[float | None, typer.Option(help="Clock drift range, +- ppm.")] = None,
    drop: Annotated[float | None, typer.Option(help="P(frame dropped).")] = None,
    setup: Annotated[int | None, typer.Option(help="Laser start-up slots before a window.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Also write the results as JSON.")] = None,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """Compare controllers on one scenario with your own settings (flags override --config)."""
    from d2sr.desync import CONTROLLERS
    from d2sr.eval import desync as ev

    if scenario not in ev.SCENARIOS:
        raise ConfigError(f"--scenario must be one of {', '.join(ev.SCENARIOS)}, got {scenario!r}")
    names = (
        split_list(controllers, "controllers", tuple(CONTROLLERS)) if controllers else list(ev.CONTROLLERS)
    )
    base = load_toml(TimingConfig, config).model_dump() if config else {}
    flags = {
        "recall": recall,
        "false_alarm": false_alarm,
        "hit_prob": hit_prob,
        "drift_ppm": drift_ppm,
        "drop": drop,
        "setup": setup,
    }
    values = {**base, **{k: v for k, v in flags.items() if v is not None}, "active_frames": fps}
    timing = TimingConfig.make(**values)
    _compare(out, scenario, sensors, fps, seconds, rooms, names, timing, seed, json_out, overwrite)


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
    overwrite: Overwrite = False,
) -> None:
    """Interference ratio against frame rate and N for every controller (paper Fig. 9 and ours)."""
    from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
    from d2sr.eval import desync as ev

    ctrl = split_list(controllers, "controllers", tuple(CONTROLLERS)) if controllers else list(ev.CONTROLLERS)
    prof = split_list(profiles, "profiles", tuple(ev.PROFILES))
    scen = split_list(scenarios, "scenarios", ev.SCENARIOS)
    fps_l, n_l = int_list(fps, "fps"), int_list(sensors, "sensors")
    if replicas < 2 or duration <= 0 or any(f < 1 or f > 30 for f in fps_l) or any(n < 1 for n in n_l):
        raise ConfigError("need replicas >= 2, duration > 0, fps in 1..30 and sensors >= 1")
    check_out(out, is_dir=True, overwrite=overwrite)
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
    with progress_bar() as bar:
        task = bar.add_task("cells", total=len(grid))
        results = ev.sweep(grid, jobs or None, progress=lambda _: bar.advance(task))
    order = {c: i for i, c in enumerate(ctrl)}
    results.sort(key=lambda r: (r.profile, r.scenario, r.fps, r.sensors, order.get(r.controller, 99)))
    command = ("d2sr desync sweep " + " ".join(sys.argv[3:])).strip()
    _report(results, out, command, overwrite)


@desync_app.command("report")
def desync_report(
    folder: Annotated[Path, typer.Argument(help="A sweep's output folder (holds sweep.json).")],
) -> None:
    """Rebuild a sweep's summary, README.md and plots from its sweep.json (no simulation), in place:
    only the files the sweep wrote are replaced."""
    from d2sr.eval import desync as ev

    check_out(folder, is_dir=True, overwrite=True)
    path = folder / "sweep.json"
    if not path.is_file():
        raise ConfigError(f"{path}: no such file (run d2sr desync sweep --out {folder} first)")
    results = ev.from_json(path.read_text())
    if not results:
        raise ConfigError(f"{path}: no results in it")
    old = folder / "summary.json"
    command = json.loads(old.read_text()).get("command", "") if old.is_file() else ""
    _report(results, folder, command or "d2sr desync sweep", overwrite=True)  # rebuilds its own output


def _report(results: list, out: Path, command: str, overwrite: bool) -> None:
    """Write CSV, JSON, summary with the bar checks, README.md and plots of sweep results."""
    from d2sr.desync import DEFAULT_CONTROLLER
    from d2sr.eval import desync as ev
    from d2sr.eval import plots

    checks = ev.check_bars(results, DEFAULT_CONTROLLER)
    head = ev.headline(results, DEFAULT_CONTROLLER)
    failed = [c for c in checks if not c["ok"]]
    summary = {"command": command, "headline_reduction_N2_15fps": head, "bars": checks, "bars_failed": failed}
    with out_dir(out, overwrite) as tmp:
        ev.write_csv(results, tmp / "sweep.csv")
        (tmp / "sweep.json").write_text(ev.to_json(results))
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
        (tmp / "README.md").write_text(ev.markdown(results, checks, head, command, DEFAULT_CONTROLLER))
        for p in dict.fromkeys(r.profile for r in results):
            plots.save(plots.fig9(results, DEFAULT_CONTROLLER, p), tmp / f"fig9_{p}.png")
            plots.save(plots.paired(results, DEFAULT_CONTROLLER, p), tmp / f"paired_{p}.png")
        plots.save(plots.convergence_cdf(results, DEFAULT_CONTROLLER), tmp / "convergence.png")
    console.print(
        f"{len(results)} cells; bars: {len(checks) - len(failed)}/{len(checks)} pass; "
        "headline (N=2, 15 fps, reduction vs static): " + ", ".join(f"{k} {v:.1%}" for k, v in head.items())
    )
    for c in failed:
        ref = c.get("reference", float("nan"))
        console.print(f"  [red]fails[/red] {c['bar']}: {c['cell']} value={c['value']:.3f} ref={ref:.3f}")
    console.print(f"Wrote {out}/README.md, sweep.csv, sweep.json, summary.json and PNG plots")


@app.command()
def bench(
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results to this JSON file.")] = None,
    what: Annotated[
        str, typer.Option(help="Benchmarks to run: timing, simulate, models, pipeline (comma-separated).")
    ] = "models",
    sensors: Annotated[int, typer.Option(help="Sensors in the timing-world benchmark.")] = 1000,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 600.0,
    repeats: Annotated[int, typer.Option(help="Repeats (median reported).")] = 3,
    overwrite: Overwrite = False,
) -> None:
    """Benchmarks: detector and recovery speed (torch, onnxruntime, from outside the process); the whole
    runtime pipeline at 640x480 and 320x240; the timing world at warehouse scale; writing simulated
    640x480 recordings."""
    from d2sr.bench import bench_models, bench_pipeline, bench_simulate, bench_timing, write_result

    names = split_list(what, "benchmark", ("timing", "simulate", "models", "pipeline"))
    if sensors < 1 or seconds <= 0 or repeats < 1:
        raise ConfigError("need sensors >= 1, seconds > 0 and repeats >= 1")
    if json_out is not None:
        check_out(json_out, is_dir=False, overwrite=overwrite)
    results = {}
    with progress_bar() as bar:
        if "timing" in names:
            task = bar.add_task(f"{sensors} sensors x {seconds:g} s, {repeats} runs", total=1.0)
            results["timing"] = bench_timing(
                sensors, seconds, repeats, progress=lambda f: bar.update(task, completed=f)
            )
        if "simulate" in names:
            task = bar.add_task(f"simulate 1000 frames, {repeats} runs", total=None)
            results["simulate"] = bench_simulate(1000, repeats)
            bar.update(task, total=1, completed=1)
        if "models" in names:
            task = bar.add_task("models", total=None)
            results["models"] = bench_models(
                repeats=max(repeats, 10) * 3, progress=lambda s: bar.update(task, description=s)
            )
            bar.update(task, total=1, completed=1)
        if "pipeline" in names:
            task = bar.add_task("pipeline", total=None)
            results["pipeline"] = bench_pipeline(
                repeats=repeats, progress=lambda s: bar.update(task, description=s)
            )
            bar.update(task, total=1, completed=1)
    result = results[names[0]] if len(names) == 1 else results
    console.print_json(write_result(result, json_out))


# Optional dependencies and the extra that brings each: an edge install (no torch) runs detect, recover, run
# and demo; training, export and evaluation need the train extra.
EXTRAS = {
    "torch": "train",
    "onnx": "train",
    "onnxscript": "train",
    "safetensors": "edge",
    "onnxruntime": "edge",
    "pyrealsense2": "realsense",
}


def main() -> None:
    """Console entry point: one-line errors with exit code 2 instead of tracebacks."""
    try:
        app()
    except D2SRError as exc:
        flush_warnings(show=False)
        print(f"d2sr: error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    except ModuleNotFoundError as exc:
        top = (exc.name or "").split(".")[0]
        if top not in EXTRAS:
            raise
        extra = EXTRAS[top]
        flush_warnings(show=False)
        print(
            f"d2sr: error: this command needs {top}, not installed: pip install 'd2sr[{extra}]'",
            file=sys.stderr,
        )
        raise SystemExit(2) from None
    finally:
        flush_warnings()  # a command that ended well (or by typer's own usage error) shows what waited
