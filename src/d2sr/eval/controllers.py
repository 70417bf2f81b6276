"""Controller comparisons behind ``d2sr desync run`` (one scenario, your settings) and the report of
``d2sr desync sweep`` (every table, plot and bar check of a sweep), written into a folder."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.eval import desync as ev
from d2sr.eval import plots
from d2sr.provenance import stamp
from d2sr.sim.timing import TimingSettings

__all__ = ["NOTES", "compare", "comparison_rows", "sweep_report"]

NOTES = {"d2sr": " (paper Alg. 1)", "oracle": " (global knowledge)", DEFAULT_CONTROLLER: " (ours, default)"}


def compare(
    folder: Path,
    rooms: ev.Cell,
    controllers: list[str],
    config: TimingSettings,
    progress: Callable[[], None] | None = None,
) -> list[ev.CellResult]:
    """Each controller on the same rooms (``rooms``: the scenario, sensors, rooms as replicas, seconds and
    seed; its controller is each of ``controllers`` in turn); per controller a timeline of room 0's slots,
    and the ratio over time of all of them, go into ``folder``."""
    scenario, sensors = rooms.scenario, rooms.sensors
    series, rows = {}, []
    for name in controllers:
        cell = dataclasses.replace(rooms, controller=name)
        cfg, graph, run = ev.simulate_cell(cell, config, record_frames=True)
        result, ratios = ev.summarize(cell, cfg, graph, run)
        series[name] = ratios.mean(axis=0)
        rows.append(result)
        shown = list(range(min(sensors, 5)))
        robot = " (sensor 0 = robot)" if scenario == "moving" else ""
        title = f"{name}: room 0, each sensor's slots over time{robot}"
        assert run.frames is not None
        timeline = plots.sensor_timeline(run.frames, config.total_frames, shown, min(run.periods, 30), title)
        plots.save(timeline, folder / f"timeline_{name}.png")
        if progress:
            progress()
    ratio = plots.ratio_over_time(series, DEFAULT_CONTROLLER, f"mean over {rooms.replicas} rooms")
    plots.save(ratio, folder / "ratio_over_time.png")
    return rows


def comparison_rows(rows: list[ev.CellResult]) -> list[list[str]]:
    """Table cells: controller, interfered (whole run), (2nd half), median convergence, vs static."""
    base = next((r.whole for r in rows if r.controller == "static"), None)
    cells = []
    for r in rows:
        med = r.converged_median
        cells.append(
            [
                r.controller + NOTES.get(r.controller, ""),
                f"{r.whole:.1%} ± {r.whole_ci:.1%}",
                f"{r.steady:.1%}",
                "never" if not np.isfinite(med) else f"{med:.0f} periods",
                f"-{1 - r.whole / base:.0%}" if base and r.controller != "static" else "n/a",
            ]
        )
    return cells


def sweep_report(results: list[ev.CellResult], folder: Path, command: str) -> dict:
    """CSV, JSON, summary with the bar checks, README.md and plots of sweep results; returns the summary."""
    checks = ev.check_bars(results, DEFAULT_CONTROLLER)
    head = ev.headline(results, DEFAULT_CONTROLLER)
    failed = [c for c in checks if not c["ok"]]
    summary = stamp({"headline_reduction_N2_15fps": head, "bars": checks, "bars_failed": failed})
    ev.write_csv(results, folder / "sweep.csv")
    (folder / "sweep.json").write_text(ev.to_json(results, stamped=True))
    (folder / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    (folder / "README.md").write_text(ev.markdown(results, checks, head, command, DEFAULT_CONTROLLER))
    for p in dict.fromkeys(r.profile for r in results):
        plots.save(plots.fig9(results, DEFAULT_CONTROLLER, p), folder / f"fig9_{p}.png")
        plots.save(plots.paired(results, DEFAULT_CONTROLLER, p), folder / f"paired_{p}.png")
    plots.save(plots.convergence_cdf(results, DEFAULT_CONTROLLER), folder / "convergence.png")
    return summary
