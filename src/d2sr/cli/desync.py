"""``d2sr desync run|sweep|report``: stage 2's controllers compared in the timing world."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from d2sr.atomic import check_out
from d2sr.cli.common import Overwrite, int_list, out_dir, renamed, split_list
from d2sr.config import load_toml
from d2sr.desync import DEFAULT_ACTIVE, TOTAL_FRAMES
from d2sr.errors import ConfigError
from d2sr.provenance import stamp
from d2sr.sim.timing import TimingSettings
from d2sr.ui import console, progress_bar

__all__ = ["grid", "report", "run", "sweep"]

Controllers = Annotated[str, typer.Option(help="Controllers, comma-separated (default: all).")]


def run(
    out: Annotated[Path, typer.Option(help="Folder for the plots.")],
    scenario: Annotated[
        str,
        typer.Option(
            help="stationary (everyone overlaps), moving (a robot), ring or row (a robot passing fixed "
            "sensors), crossing (two robots)."
        ),
    ] = "stationary",
    sensors: Annotated[int, typer.Option(help="Sensors, robots included.")] = 3,
    active_frames: Annotated[int, typer.Option(help="Frames a 1 s period (30: always on).")] = DEFAULT_ACTIVE,
    fps: Annotated[int | None, typer.Option(hidden=True, help="Deprecated: --active-frames.")] = None,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 60.0,
    rooms: Annotated[int, typer.Option(help="Independent rooms averaged.")] = 20,
    controllers: Controllers = "",
    config: Annotated[
        Path | None, typer.Option(help="TOML with timing-world settings (TimingSettings).")
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
    """Compare controllers on one scenario with your own settings (flags override --config).

    Example: d2sr desync run --sensors 2 --active-frames 15 --recall 0.7 --out out/desync
    """
    from d2sr.desync import CONTROLLERS
    from d2sr.eval import desync as ev
    from d2sr.eval.controllers import compare, comparison_rows

    fps = renamed("--fps", "--active-frames", fps, active_frames)
    if scenario not in ev.SCENARIOS:
        raise ConfigError(f"--scenario must be one of {', '.join(ev.SCENARIOS)}, got {scenario!r}")
    names = split_list(controllers, "controllers", tuple(CONTROLLERS)) if controllers else list(ev.COMPARED)
    if sensors < 1 or rooms < 2:
        raise ConfigError("need --sensors >= 1 and --rooms >= 2")
    base = load_toml(TimingSettings, config).model_dump() if config else {}
    flags = {
        "recall": recall,
        "false_alarm": false_alarm,
        "hit_prob": hit_prob,
        "drift_ppm": drift_ppm,
        "drop": drop,
        "setup": setup,
    }
    values = {**base, **{k: v for k, v in flags.items() if v is not None}, "active_frames": fps}
    timing = TimingSettings.make(**values)
    check_out(out, is_dir=True, overwrite=overwrite)
    if json_out:
        check_out(json_out, is_dir=False, overwrite=overwrite, name="json")
    where = "one room" if scenario == "stationary" else ev.TITLES[scenario].split(" (")[0]
    with out_dir(out, overwrite) as tmp, progress_bar() as bar:
        task = bar.add_task("simulating", total=len(names))
        grid = ev.Cell(scenario, fps, sensors, names[0], replicas=rooms, duration_s=seconds, seed=seed)
        rows = compare(tmp, grid, names, timing, lambda: bar.advance(task))
    table = Table(
        title=f"{sensors} sensors, {where}, {fps} of {timing.total_frames} frames per second, "
        f"{seconds:g} s, {rooms} rooms"
    )
    for i, col in enumerate(
        ("controller", "interfered (whole run)", "interfered (2nd half)", "median convergence", "vs static")
    ):
        table.add_column(col, justify="left" if i == 0 else "right")
    for cells in comparison_rows(rows):
        table.add_row(*cells)
    console.print(table)
    if scenario == "moving":
        console.print("Moving robot: the ratios count the robot's frames only (as in the paper).")
    console.print(f"Plots: {out}/timeline_<controller>.png, {out}/ratio_over_time.png")
    if json_out:
        from d2sr.atomic import atomic_write

        atomic_write(json_out, ev.to_json(rows, stamped=True))
        console.print(f"Results: {json_out}")


def sweep(
    out: Annotated[Path, typer.Option(help="Folder for CSV, JSON, plots and summary.")],
    replicas: Annotated[int, typer.Option(help="Independent rooms per cell.")] = 20,
    seconds: Annotated[float, typer.Option(help="Simulated seconds per run.")] = 60.0,
    duration: Annotated[float | None, typer.Option(hidden=True, help="Deprecated: --seconds.")] = None,
    active_frames: Annotated[
        str, typer.Option(help="Frames per 1 s period, comma-separated.")
    ] = "6,10,15,20,25,30",
    fps: Annotated[str | None, typer.Option(hidden=True, help="Deprecated: --active-frames.")] = None,
    sensors: Annotated[str, typer.Option(help="Sensor counts, comma-separated.")] = "1,2,3,4,5",
    controllers: Controllers = "",
    scenarios: Annotated[
        str, typer.Option(help="Any of stationary,moving,ring,row,crossing.")
    ] = "stationary,moving",
    profiles: Annotated[str, typer.Option(help="Noise profiles: default,harsh.")] = "default,harsh",
    jobs: Annotated[int, typer.Option(help="Worker processes (0 = all cores).")] = 0,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """Interference ratio against frame rate and N for every controller (paper Fig. 9 and ours).

    Example: d2sr desync sweep --replicas 10 --seconds 30 --out out/sweep
    """
    from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
    from d2sr.eval import desync as ev

    duration = renamed("--duration", "--seconds", duration, seconds)
    fps = renamed("--fps", "--active-frames", fps, active_frames)
    ctrl = split_list(controllers, "controllers", tuple(CONTROLLERS)) if controllers else list(ev.COMPARED)
    prof = split_list(profiles, "profiles", tuple(ev.PROFILES))
    scen = split_list(scenarios, "scenarios", ev.SCENARIOS)
    fps_l, n_l = int_list(fps, "active-frames"), int_list(sensors, "sensors")
    if (
        replicas < 2
        or duration <= 0
        or any(f < 1 or f > TOTAL_FRAMES for f in fps_l)
        or any(n < 1 for n in n_l)
    ):
        raise ConfigError("need replicas >= 2, duration > 0, fps in 1..30 and sensors >= 1")
    check_out(out, is_dir=True, overwrite=overwrite)
    grid = ev.cells(scen, fps_l, n_l, ctrl, ["default"], replicas, duration, seed)
    if "harsh" in prof:  # robustness: only the default and Algorithm 1 are rerun
        harsh = [c for c in ctrl if c in ("d2sr", DEFAULT_CONTROLLER)]
        grid += ev.cells(scen, fps_l, n_l, harsh, ["harsh"], replicas, duration, seed)
    with progress_bar() as bar:
        task = bar.add_task("cells", total=len(grid))
        results = ev.sweep(grid, jobs or None, progress=lambda _: bar.advance(task))
    order = {c: i for i, c in enumerate(ctrl)}
    results.sort(key=lambda r: (r.profile, r.scenario, r.fps, r.sensors, order.get(r.controller, 99)))
    _report(results, out, ("d2sr desync sweep " + " ".join(sys.argv[3:])).strip(), overwrite)


def report(
    folder: Annotated[
        Path, typer.Argument(help="A sweep's output folder (holds sweep.json).", metavar="FOLDER")
    ],
) -> None:
    """Rebuild a sweep's summary, README.md and plots from its sweep.json (no simulation), in place:
    only the files the sweep wrote are replaced.

    Example: d2sr desync report out/sweep
    """
    from d2sr.eval import desync as ev

    check_out(folder, is_dir=True, overwrite=True, name="FOLDER")
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
    from d2sr.eval.controllers import sweep_report

    with out_dir(out, overwrite) as tmp:
        summary = sweep_report(results, tmp, command)
    checks, failed, head = summary["bars"], summary["bars_failed"], summary["headline_reduction_N2_15fps"]
    console.print(
        f"{len(results)} cells; bars: {len(checks) - len(failed)}/{len(checks)} pass; "
        "headline (N=2, 15 fps, reduction vs static): " + ", ".join(f"{k} {v:.1%}" for k, v in head.items())
    )
    for c in failed:
        ref = c.get("reference", float("nan"))
        console.print(f"  [red]fails[/red] {c['bar']}: {c['cell']} value={c['value']:.3f} ref={ref:.3f}")
    console.print(f"Wrote {out}/README.md, sweep.csv, sweep.json, summary.json and PNG plots")


def grid(
    out: Annotated[Path, typer.Option(help="Folder for grid.json, grid.png and README.md.")],
    controller: Annotated[str, typer.Option(help="The controller to judge (default: the default).")] = "",
    settings: Annotated[int, typer.Option(help="Joint settings of the assumptions per room.")] = 12,
    replicas: Annotated[int, typer.Option(help="Independent rooms per cell.")] = 20,
    seconds: Annotated[float, typer.Option(help="Simulated seconds per run.")] = 60.0,
    jobs: Annotated[int, typer.Option(help="Worker processes (0 = all cores).")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """The controller against the paper's Algorithm 1 across what deployments vary: overlap share, laser
    start-up, hit probability, detector recall and false alarms, drift; two sensors at every frame rate
    and crowded rooms; the oracle where the period is oversubscribed. A heat map of the difference.

    Example: d2sr desync grid --out out/grid"""
    from d2sr.desync import CONTROLLERS, DEFAULT_CONTROLLER
    from d2sr.eval import assumptions as ea
    from d2sr.eval.plots import save

    name = controller or DEFAULT_CONTROLLER
    if name not in CONTROLLERS or name == "oracle":
        raise ConfigError(
            f"--controller must be a decentralized controller ({', '.join(CONTROLLERS)}), got {name!r}"
        )
    if settings < 1 or replicas < 2 or seconds <= 0:
        raise ConfigError("need --settings >= 1, --replicas >= 2 and --seconds > 0")
    check_out(out, is_dir=True, overwrite=overwrite)
    names = list(dict.fromkeys([name, "d2sr", "oracle"]))
    with progress_bar() as bar:
        n_cells = sum(
            1 + 1 + ea.oversubscribed(n, f, s["setup"]) for n, f in ea.ROOMS for s in ea.settings(settings)
        )
        task = bar.add_task("cells", total=n_cells)
        sets, results = ea.run_grid(
            names, settings, replicas, seconds, jobs=jobs or None, progress=lambda: bar.advance(task)
        )
    summ = ea.summary(sets, results, name)
    command = ("d2sr desync grid " + " ".join(sys.argv[3:])).strip()
    with out_dir(out, overwrite) as tmp:
        (tmp / "grid.json").write_text(json.dumps(stamp(summ), indent=1, default=float) + "\n")
        (tmp / "README.md").write_text(ea.markdown(summ, command))
        save(ea.heatmap(summ), tmp / "grid.png")
    w = summ["worst"]
    console.print(
        f"{name} vs d2sr over {len(summ['cells'])} cells: mean {summ['mean_diff_points']:+.2f} points, "
        f"worst {w['diff_points']:+.2f} (N={w['sensors']}, {w['fps']} fps, setting {w['setting']}); "
        f"cells losing by more than 0.3 points: {summ['cells_losing_over_0.3']}; oversubscribed worst vs "
        f"oracle {summ['oversubscribed_worst_vs_oracle']:.2f}. Wrote {out}/README.md, grid.json, grid.png"
    )
