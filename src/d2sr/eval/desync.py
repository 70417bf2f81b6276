"""The de-synchronization sweep: interference ratio against frame rate and sensor count (paper Fig. 9).

Every cell (scenario, frames per second, sensors N, controller, noise profile) runs ``replicas``
independent rooms side by side in one timing world (disconnected copies of the overlap graph), so one
vectorized run gives a mean with a confidence interval. Controllers in the same cell see the same seed,
hence the same phases, drifts and per-frame luck: their differences are paired.

Metrics, per replica, then averaged:
- ``whole``: interfered / captured frames over the whole run, adjustment time included;
- ``steady``: the same over the second half of the run;
- ``converged``: first period from which the replica's interference ratio, averaged over a 5-period
  window, stays at or below 5% until the end (censored when it never does).
In the moving-robot scenario only the robot's stream counts, as in the paper. In the passing worlds
(``d2sr.sim.passing``: a robot passing a ring or a row of fixed sensors, two robots crossing) every sensor's
frames count: what a robot costs the sensors it passes is part of the measure.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.errors import InputError
from d2sr.frames.overlap import processes
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.passing import WORLDS, passing_rooms
from d2sr.sim.timing import TimingRun, TimingSettings, simulate
from d2sr.version import __version__

__all__ = [
    "COMPARED",
    "FPS",
    "PAPER_SCENARIOS",
    "PROFILES",
    "SCENARIOS",
    "SENSORS",
    "TITLES",
    "Cell",
    "CellResult",
    "convergence_periods",
    "run_cell",
    "simulate_cell",
    "summarize",
    "sweep",
]

FPS = (6, 10, 15, 20, 25, 30)
SENSORS = (1, 2, 3, 4, 5)
SCENARIOS = ("stationary", "moving", *WORLDS)
#: What a sweep runs unless told: the paper's two scenarios.
PAPER_SCENARIOS = ("stationary", "moving")
#: One line per scenario, for reports.
TITLES = {
    "stationary": "stationary",
    "moving": "moving (the robot's frames only)",
    "ring": "a robot passing a ring (every sensor's frames)",
    "row": "a robot passing a row (every sensor's frames)",
    "crossing": "two robots crossing (every sensor's frames)",
}
COMPARED = ("static", "d2sr", DEFAULT_CONTROLLER, "oracle")  # what the sweep and desync run compare
#: Noise profiles: the issue's defaults and the robustness check.
PROFILES: dict[str, dict[str, float]] = {
    "default": {"recall": 0.9, "false_alarm": 0.01, "drift_ppm": 50.0, "drop": 0.0},
    "harsh": {"recall": 0.7, "false_alarm": 0.05, "drift_ppm": 200.0, "drop": 0.05},
}
WINDOW, CONVERGED = 5, 0.05


@dataclass(frozen=True)
class Cell:
    scenario: str
    fps: int
    sensors: int
    controller: str
    profile: str = "default"
    replicas: int = 20
    duration_s: float = 60.0
    seed: int = 0


@dataclass(frozen=True)
class CellResult:
    scenario: str
    fps: int
    sensors: int
    controller: str
    profile: str
    slack: bool
    whole: float
    whole_ci: float
    steady: float
    steady_ci: float
    converged_median: float
    converged_p90: float
    never_converged: float
    #: per replica: first converged period (inf = never); stationary rooms only are meaningful
    converged: tuple[float, ...] = ()
    #: per replica whole-run ratio (replicas are paired across controllers of a cell: same seed)
    per_replica: tuple[float, ...] = ()


def has_slack(sensors: int, fps: int, setup: int = 2, total: int = 30) -> bool:
    """The issue's slack condition: N x (n + setup) <= 0.85 x period."""
    return sensors * (fps + setup) <= 0.85 * total


def convergence_periods(ratios: np.ndarray) -> np.ndarray:
    """Per row (replica) the first period whose 5-period windows all stay <= 5% to the end; inf if none."""
    reps, periods = ratios.shape
    if periods < WINDOW:
        return np.full(reps, np.inf)
    kernel = np.ones(WINDOW) / WINDOW
    out = np.full(reps, np.inf)
    for r in range(reps):
        windowed = np.convolve(ratios[r], kernel, mode="valid")  # window starting at each period
        bad = np.flatnonzero(windowed > CONVERGED)
        if bad.size == 0:
            out[r] = 0
        elif bad[-1] + 1 < windowed.size:
            out[r] = bad[-1] + 1
    return out


def _graph(cell: Cell) -> OverlapGraph:
    if cell.scenario == "stationary":
        return OverlapGraph.complete(cell.sensors).replicate(cell.replicas)
    if cell.scenario == "moving":
        rooms = [
            OverlapGraph.moving_robot(cell.sensors, cell.duration_s, seed=cell.seed * 7919 + r)
            for r in range(cell.replicas)
        ]
        return OverlapGraph.disjoint(rooms)
    if cell.scenario in WORLDS:
        return passing_rooms(cell.scenario, cell.sensors, cell.duration_s, cell.replicas, cell.seed)
    raise ValueError(f"unknown scenario {cell.scenario!r}")


def run_cell(cell: Cell, config: TimingSettings | None = None, **overrides: float) -> CellResult:
    """Simulate one cell and summarize it. ``config`` replaces the profile (its fps is the cell's)."""
    return summarize(cell, *simulate_cell(cell, config, False, **overrides))[0]


def simulate_cell(
    cell: Cell, config: TimingSettings | None = None, record_frames: bool = False, **overrides: float
) -> tuple[TimingSettings, OverlapGraph, TimingRun]:
    """The cell's rooms in one timing world, run with the cell's controller."""
    if config is None:
        config = TimingSettings.make(active_frames=cell.fps, **{**PROFILES[cell.profile], **overrides})
    graph = _graph(cell)
    run = simulate(
        graph, cell.controller, config, cell.duration_s, seed=cell.seed, record_frames=record_frames
    )
    return config, graph, run


def summarize(
    cell: Cell, cfg: TimingSettings, graph: OverlapGraph, run: TimingRun
) -> tuple[CellResult, np.ndarray]:
    """The cell's metrics, and each room's per-period interference ratio (rooms x periods)."""
    per_room = graph.n // cell.replicas
    room = np.arange(graph.n) // per_room
    focus = graph.focus if graph.focus is not None else np.arange(graph.n)
    half = run.periods // 2
    cap = np.zeros((cell.replicas, run.periods))
    bad = np.zeros((cell.replicas, run.periods))
    np.add.at(cap, room[focus], run.captured[focus])
    np.add.at(bad, room[focus], run.interfered[focus])

    def per_replica(start: int) -> np.ndarray:
        c = cap[:, start:].sum(1)
        return np.divide(bad[:, start:].sum(1), c, out=np.zeros(cell.replicas), where=c > 0)

    whole, steady = per_replica(0), per_replica(half)
    ratios = np.divide(bad, cap, out=np.zeros_like(bad), where=cap > 0)
    conv = convergence_periods(ratios)
    finite = conv[np.isfinite(conv)]
    ci = 1.96 / np.sqrt(cell.replicas)
    return CellResult(
        cell.scenario,
        cell.fps,
        cell.sensors,
        cell.controller,
        cell.profile,
        has_slack(cell.sensors, cell.fps, cfg.setup, cfg.total_frames),
        float(whole.mean()),
        float(whole.std(ddof=1) * ci) if cell.replicas > 1 else 0.0,
        float(steady.mean()),
        float(steady.std(ddof=1) * ci) if cell.replicas > 1 else 0.0,
        float(np.median(conv)),
        float(np.quantile(conv, 0.9)) if finite.size == conv.size else float("inf"),
        float(np.mean(~np.isfinite(conv))),
        tuple(float(c) for c in conv),
        tuple(float(w) for w in whole),
    ), ratios


def cells(
    scenarios: Iterable[str] = PAPER_SCENARIOS,
    fps: Iterable[int] = FPS,
    sensors: Iterable[int] = SENSORS,
    controllers: Iterable[str] = COMPARED,
    profiles: Iterable[str] = ("default",),
    replicas: int = 20,
    duration_s: float = 60.0,
    seed: int = 0,
) -> list[Cell]:
    """The grid of cells, slowest (oracle, many sensors) first so parallel workers finish together."""
    grid = [
        # only the robot counts in the moving scenario: five times the rooms for a comparable interval
        Cell(sc, f, n, c, p, replicas * (5 if sc == "moving" else 1), duration_s, seed)
        for p in profiles
        for sc in scenarios
        for f in fps
        for n in sensors
        for c in controllers
    ]
    return sorted(grid, key=lambda c: (c.controller != "oracle", -c.sensors))


def sweep(
    grid: list[Cell], jobs: int | None = None, progress: Callable[[CellResult], None] | None = None
) -> list[CellResult]:
    """Run every cell, in parallel processes; results in the grid's order."""
    jobs = jobs or min(len(grid), os.cpu_count() or 1)
    if jobs <= 1:
        out = []
        for c in grid:
            out.append(run_cell(c))
            if progress:
                progress(out[-1])
        return out
    with processes(jobs) as pool:
        futures = [pool.submit(run_cell, c) for c in grid]
        results = []
        for f in futures:
            results.append(f.result())
            if progress:
                progress(results[-1])
    return results


def to_json(results: list[CellResult], stamped: bool = False) -> str:
    """Results as JSON (inf written as null): a list, or with ``stamped`` an object that says d2sr made it
    (``{"made_by": ..., "results": [...]}``, a file ``--overwrite`` may replace)."""

    def fin(v: object) -> object:
        if isinstance(v, float) and not np.isfinite(v):
            return None
        if isinstance(v, tuple | list):
            return [fin(x) for x in v]
        return v

    def clean(d: dict) -> dict:
        return {k: fin(v) for k, v in d.items()}

    rows = [clean(asdict(r)) for r in results]
    if stamped:
        from d2sr.provenance import stamp

        return json.dumps(stamp({"results": rows}), indent=1)
    return json.dumps(rows, indent=1)


def from_json(text: str) -> list[CellResult]:
    """Results back from ``to_json`` (null read back as inf)."""

    def back(v: Any) -> Any:
        if v is None:
            return float("inf")
        if isinstance(v, list):
            return tuple(back(x) for x in v)
        return v

    try:
        rows = json.loads(text)
        if isinstance(rows, dict):  # stamped: {"made_by": ..., "results": [...]}
            rows = rows["results"]
        return [CellResult(**{k: back(v) for k, v in row.items()}) for row in rows]
    except (json.JSONDecodeError, TypeError, AttributeError, KeyError) as exc:
        raise InputError(f"not a sweep.json written by d2sr: {exc}") from None


def write_csv(results: list[CellResult], path: Path) -> None:
    """Results as CSV, written to a temporary name and renamed."""
    import csv

    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as fh:
        fields = [f for f in CellResult.__dataclass_fields__ if f not in ("converged", "per_replica")]
        w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in results:
            w.writerow(asdict(r))
    tmp.replace(path)


# ------------------------------------------------------------------------------------------ bars
def _index(results: list[CellResult]) -> dict[tuple[str, str, int, int, str], CellResult]:
    return {(r.profile, r.scenario, r.fps, r.sensors, r.controller): r for r in results}


def check_bars(
    results: list[CellResult], default: str = DEFAULT_CONTROLLER, tol: float = 0.005
) -> list[dict]:
    """The issue's bars, evaluated on sweep results: one dict per check (``ok`` and the numbers)."""
    by = _index(results)
    checks: list[dict] = []
    for (prof, sc, f, n, ctrl), r in sorted(by.items()):
        if prof != "default" or ctrl != default or n < 2:
            continue
        ref, orc = by.get((prof, sc, f, n, "d2sr")), by.get((prof, sc, f, n, "oracle"))
        cell = f"{sc} {f} fps N={n}"
        if r.slack:
            checks.append(
                {"bar": "slack: steady <= 5%", "cell": cell, "value": r.steady, "ok": r.steady <= 0.05}
            )
            if sc == "stationary":
                checks.append(
                    {
                        "bar": "slack: median convergence <= 10 periods",
                        "cell": cell,
                        "value": r.converged_median,
                        "ok": r.converged_median <= 10,
                    }
                )
        if ref and orc and ref.whole > orc.whole + tol:
            checks.append(
                {
                    "bar": "whole < d2sr where d2sr > oracle",
                    "cell": cell,
                    "value": r.whole,
                    "reference": ref.whole,
                    "ok": r.whole < ref.whole,
                    **_paired(r, ref),
                }
            )
        if orc and not r.slack:
            limit = 1.5 * orc.whole
            checks.append(
                {
                    "bar": "oversubscribed: whole <= 1.5 x oracle",
                    "cell": cell,
                    "value": r.whole,
                    "reference": orc.whole,
                    "ok": r.whole <= limit + tol,
                }
            )
        harsh = by.get(("harsh", sc, f, n, ctrl))
        if harsh:
            for metric in ("whole", "steady"):
                loss = getattr(harsh, metric) - getattr(r, metric)
                checks.append(
                    {
                        "bar": f"harsh profile loses <= 5 points ({metric})",
                        "cell": cell,
                        "value": loss,
                        "ok": loss <= 0.05,
                    }
                )
    return checks


def _paired(r: CellResult, ref: CellResult) -> dict:
    """Mean per-room difference r - ref with its 95% interval (rooms share seeds: paired)."""
    diff = np.array(r.per_replica) - np.array(ref.per_replica)
    if diff.size < 2:
        return {}
    half = float(1.96 * diff.std(ddof=1) / np.sqrt(diff.size))
    return {
        "paired_diff": float(diff.mean()),
        "paired_ci95": half,
        "significantly_worse": bool(diff.mean() > half),
    }


def headline(results: list[CellResult], default: str = DEFAULT_CONTROLLER) -> dict[str, float]:
    """The paper's headline: reduction of interfered frames against static for N = 2 at half frame rate."""
    by = _index(results)
    out: dict[str, float] = {"paper_d2sr": 0.703}
    base = by.get(("default", "stationary", 15, 2, "static"))
    for ctrl in ("d2sr", default, "oracle"):
        r = by.get(("default", "stationary", 15, 2, ctrl))
        if base and r and base.whole > 0:
            out[ctrl] = 1.0 - r.whole / base.whole
    return out


def markdown(
    results: list[CellResult],
    checks: list[dict],
    head: dict[str, float],
    command: str,
    default: str = DEFAULT_CONTROLLER,
) -> str:
    """A readable report of a sweep: tables of whole-run ratios, the bar checks, the headline."""
    by = _index(results)
    lines = [
        "# De-synchronization sweep",
        "",
        f"Made by `{command}` (d2sr {__version__}). Plots beside this file:",
        "`fig9_<profile>.png` (paper Fig. 9 layout), `paired_<profile>.png` (every cell, default against",
        "Algorithm 1 and the oracle), `convergence.png`. Raw numbers: `sweep.csv`, `sweep.json`; checks:",
        "`summary.json`.",
        "",
        "Whole-run interference ratio (interfered / captured frames, adjustment included), mean over rooms;",
        "`harsh` is the default controller under recall 0.7, false alarm 5%, drift ±200 ppm, 5% drops.",
        "Bold: cells with slack (N x (n + 2) <= 25.5).",
    ]
    for sc in SCENARIOS:
        rows = sorted({(r.fps, r.sensors) for r in results if r.scenario == sc and r.sensors > 1})
        if not rows:
            continue
        lines += [
            "",
            f"## {TITLES[sc]}",
            "",
            f"| fps | N | static | d2sr (paper) | {default} (ours) | oracle "
            f"| {default} steady | {default} harsh |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for f, n in rows:
            cell = {c: by.get(("default", sc, f, n, c)) for c in COMPARED}
            harsh = by.get(("harsh", sc, f, n, default))
            d = cell.get(default)

            def pct(r: CellResult | None) -> str:
                return "" if r is None else f"{r.whole:.1%}"

            slack = d is not None and d.slack
            label = f"**{f}** | **{n}**" if slack else f"{f} | {n}"
            lines.append(
                f"| {label} | {pct(cell.get('static'))} | {pct(cell.get('d2sr'))} | {pct(d)} | "
                f"{pct(cell.get('oracle'))} | {'' if d is None else f'{d.steady:.1%}'} | {pct(harsh)} |"
            )
    failed = [c for c in checks if not c["ok"]]
    lines += ["", "## Bars", "", f"{len(checks) - len(failed)} of {len(checks)} checks pass.", ""]
    for name in dict.fromkeys(c["bar"] for c in checks):
        group = [c for c in checks if c["bar"] == name]
        bad = [c for c in group if not c["ok"]]
        lines.append(f"- {name}: {len(group) - len(bad)}/{len(group)} pass")
        for c in bad:
            extra = ""
            if "paired_diff" in c:
                sig = "significant" if c["significantly_worse"] else "not significant"
                extra = f"; paired difference {c['paired_diff']:+.3f} ± {c['paired_ci95']:.3f} ({sig})"
            ref = f" vs {c['reference']:.3f}" if "reference" in c else ""
            lines.append(f"  - fails at {c['cell']}: {c['value']:.3f}{ref}{extra}")
    lines += [
        "",
        "## Headline: N = 2 at half frame rate (15 fps), reduction of interfered frames vs static",
        "",
    ]
    lines += [f"- {k}: {v:.1%}" for k, v in head.items()]
    return "\n".join(lines) + "\n"
