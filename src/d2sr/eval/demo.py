"""``make demo``: the whole closed loop, three simulated L515s in one room, under three controllers.

Each run is the runtime users run (``d2sr run sim``): every sensor renders its frames, detects with the
shipped detector, feeds its own controller, moves its own window through its trigger, and repairs what it
flags with the shipped models (``auto``). The controllers meet the same room, phases and luck (paired
comparison).
"""

from __future__ import annotations

import csv
import functools
import json
import time
from collections.abc import Callable
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from d2sr.atomic import atomic_dir
from d2sr.contract.catalog import DEFAULT_MODEL
from d2sr.desync import DEFAULT_CONTROLLER, TOTAL_FRAMES
from d2sr.desync.base import DEFAULT_ACTIVE
from d2sr.errors import ConfigError
from d2sr.eval.plots import ratio_over_time, save, sensor_timeline
from d2sr.frames.base import positive_finite
from d2sr.jobs.session import run_sim
from d2sr.runtime.backends import Backend
from d2sr.runtime.loop import Result
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.sim.record import MAX_SECONDS
from d2sr.sim.timing import TimingSettings

__all__ = ["CAPTION", "DEMO_CONTROLLERS", "HEADERS", "markdown_table", "read_log", "run_demo", "table_rows"]

DEMO_CONTROLLERS = ("static", "d2sr", DEFAULT_CONTROLLER)


def read_log(path: Path, sensors: int, periods: int) -> tuple[np.ndarray, np.ndarray]:
    """(frames, flagged) as sensors x slots from a run's log: 0 idle, 1 clean, 2 interfered."""
    frames = np.zeros((sensors, periods * TOTAL_FRAMES), np.int8)
    flagged = np.zeros_like(frames, dtype=bool)
    with path.open(newline="") as fh:
        for row in csv.DictReader(fh):
            s, g = int(row["sensor"]), int(row["frame"])
            if g < frames.shape[1]:
                frames[s, g] = 1 + int(row["interfered"])
                flagged[s, g] = row["flagged"] == "1"
    return frames, flagged


def _examples(items: list[tuple[int, Result]], path: Path) -> Path:
    """Input, true mask, predicted mask, repair and truth of a few frames, depth in metres on one colour
    scale per row (with its colour bar), masks white where interfered."""
    cols = ["input (interfered)", "true mask", "predicted mask", "repaired", "ground truth (clean)"]
    fig, axes = plt.subplots(len(items), 5, figsize=(16, 2.5 * len(items)), squeeze=False)
    for row, (sensor, res) in zip(axes, items, strict=True):
        cap = res.capture
        assert cap.clean is not None and cap.mask is not None
        scale = np.float32(cap.scale)
        hi = float(np.percentile(cap.clean[cap.clean > 0], 99)) / scale if (cap.clean > 0).any() else 1.0
        shown = None
        for ax, img in zip(row, [cap.frame.depth, cap.mask, res.mask, res.depth, cap.clean], strict=True):
            if img.dtype == bool:
                ax.imshow(img, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            else:
                shown = ax.imshow(img / scale, cmap="turbo", vmin=0, vmax=hi, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if ax is row[0]:
                ax.set_ylabel(f"sensor {sensor}, frame {cap.name}", fontsize=8)
        for ax, col in zip(row, cols, strict=True):
            ax.set_title(col, fontsize=9)
        assert shown is not None
        fig.colorbar(shown, ax=list(row), fraction=0.015, pad=0.01, label="depth (m); 0 = no return")
    fig.suptitle(
        "Frames the static controller's sensors flagged: masks are white where interfered", fontsize=10
    )
    return save(fig, path)


def run_demo(
    net: Backend,
    out: Path,
    seconds: float = 20.0,
    sensors: int = 3,
    active_frames: int = DEFAULT_ACTIVE,
    seed: int = 0,
    progress: Callable[[str, float], None] | None = None,
) -> dict:
    """Run each controller's closed loop; write runs, plots, ``results.json`` and ``report.md``."""
    if not (positive_finite(seconds) and seconds <= MAX_SECONDS):  # inf overflowed, 1e9 ran for ever
        raise ConfigError(f"seconds must be in (0, {MAX_SECONDS:g}] for the demo, got {seconds}", "seconds")
    periods = round(seconds * TimingSettings().fps / TOTAL_FRAMES)
    results: dict[str, dict] = {}
    examples: list[tuple[int, Result]] = []

    def keep(sensor: int, res: Result) -> None:  # a few repaired frames from different sensors
        cap = res.capture
        big = cap.mask is not None and cap.mask.mean() > 0.02
        if res.flagged and big and len(examples) < 3 and all(s != sensor for s, _ in examples):
            examples.append((sensor, res))

    with atomic_dir(out) as tmp:
        for name in DEMO_CONTROLLERS:
            t = time.perf_counter()
            plan = LoopSettings(
                controller=name, sensors=sensors, seconds=seconds, active_frames=active_frames, seed=seed
            )
            results[name] = run_sim(
                net, tmp / "runs" / name, RunSettings(scene=False), plan,
                progress=functools.partial(progress, name) if progress else None,
                on_result=keep if name == "static" else None,
            )  # fmt: skip
            results[name]["wall_s"] = round(time.perf_counter() - t, 2)
        plots = []
        series = {}
        for name in DEMO_CONTROLLERS:
            frames, flagged = read_log(tmp / "runs" / name / "log.csv", sensors, periods)
            title = f"{name}: each sensor's slots over {periods} periods (closed loop, shipped models)"
            plots.append(
                save(
                    sensor_timeline(frames, TOTAL_FRAMES, range(sensors), periods, title, flagged),
                    tmp / f"timeline_{name}.png",
                )
            )
            per = frames.reshape(sensors, periods, TOTAL_FRAMES)
            cap = (per > 0).sum(axis=(0, 2))
            series[name] = np.where(cap > 0, (per == 2).sum(axis=(0, 2)) / np.maximum(cap, 1), 0.0)
        plots.append(
            save(
                ratio_over_time(series, DEFAULT_CONTROLLER, f"{sensors} sensors"), tmp / "ratio_over_time.png"
            )
        )
        if examples:
            plots.append(_examples(examples, tmp / "examples.png"))
        report = {
            "scenario": {
                "sensors": sensors,
                "seconds": seconds,
                "active_frames": active_frames,
                "seed": seed,
                "backend": net.name,
            },
            "controllers": {k: v["all"] | {"wall_s": v["wall_s"]} for k, v in results.items()},
            "per_sensor": {k: v["sensors"] for k, v in results.items()},
        }
        (tmp / "results.json").write_text(json.dumps(report, indent=1) + "\n")
        (tmp / "report.md").write_text(_markdown(report, [p.name for p in plots]))
    return report


def _fmt(v: object) -> str:
    return "-" if v is None else str(v)


def table_rows(report: dict) -> list[list[str]]:
    """The demo's table (``HEADERS``): what the terminal prints and report.md holds, the same rows."""
    rows = []
    base = report["controllers"]["static"]["interfered_ratio"]
    for name, r in report["controllers"].items():
        ratio = r.get("interfered_ratio", 0.0)
        vs = "" if name == "static" or not base else f"-{1 - ratio / base:.0%}"
        rows.append(
            [
                name + (" (default)" if name == DEFAULT_CONTROLLER else ""),
                f"{r.get('interfered', 0)}/{r['frames']}",
                vs,
                _fmt(r.get("precision")),
                _fmt(r.get("recall")),
                _fmt(r.get("rmse_before_cm")),
                _fmt(r.get("rmse_after_cm")),
                _fmt(r.get("fps")),
            ]
        )
    return rows


# Short enough for an 80-column terminal; CAPTION says what each means.
HEADERS = ["controller", "interfered", "vs static", "P", "R", "RMSE in", "RMSE out", "fps"]
CAPTION = (
    "interfered: frames another sensor's laser hit, of all frames delivered; vs static: change in that "
    "count; P, R: the detector's precision and recall against the simulator's truth; RMSE in, out (cm): "
    "depth error over the interfered frames' valid pixels before and after repair; fps: detect + repair "
    "per delivered frame (median; machine-dependent)."
)


def _markdown(report: dict, plots: list[str]) -> str:
    sc = report["scenario"]
    lines = [
        "# d2sr demo: the closed loop in a simulated room",
        "",
        f"{sc['sensors']} simulated L515s share one room for {sc['seconds']:g} s, each running "
        f"{sc['active_frames']} of {TOTAL_FRAMES} frames per second. Every sensor runs its own loop "
        f"(shipped detector and `{DEFAULT_MODEL}` repair, {sc['backend']}): detect, de-synchronize through "
        "its own trigger, repair what it flags.",
        "",
        "Command: `make demo` (`d2sr demo --out out/demo`).",
        "",
        *markdown_table(report),
        "",
        CAPTION,
        "",
    ]
    for p in plots:
        lines += [f"![{p}]({p})", "", f"*{_caption(p)}*", ""]
    return "\n".join(lines)


def markdown_table(report: dict) -> list[str]:
    """The table as markdown lines (the README quotes these rows)."""
    lines = ["| " + " | ".join(HEADERS) + " |", "|" + "---|" * len(HEADERS)]
    return lines + ["| " + " | ".join(r) + " |" for r in table_rows(report)]


def _caption(plot: str) -> str:
    if plot.startswith("timeline_"):
        name = plot.removeprefix("timeline_").removesuffix(".png")
        return (
            f"{name}: each sensor's 30 slots of every 1 s period: green a clean frame, red an interfered "
            "one, grey the laser idle; a dot marks a frame its detector flagged."
        )
    if plot == "ratio_over_time.png":
        return (
            "Share of delivered frames interfered in each 1 s period, per controller (all sensors together)."
        )
    if plot == "examples.png":
        return (
            "Example frames under the static controller: depth in metres (colour bar), masks white where hit."
        )
    return plot
