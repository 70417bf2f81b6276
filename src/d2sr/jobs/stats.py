"""What a run measured, per sensor: frames, interference, detection against the truth (when a source
knows it), depth error before and after repair, and processing time."""

from __future__ import annotations

import statistics
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rich.table import Table

from d2sr.runtime.loop import Result
from d2sr.ui import NA

__all__ = ["RunStats", "median_p99_ms", "stats_table"]

BINS = 20_000  # up to 2 s


@dataclass
class RunStats:
    frames: int = 0
    flagged: int = 0
    interfered: int = 0  # truth known
    true_flags: int = 0
    truth_known: int = 0
    se_before: float = 0.0  # squared error (m^2) over valid clean pixels of interfered frames
    se_after: float = 0.0
    n_valid: int = 0
    scene_judged: int = 0  # frames the sensor's scene was judged on (``Result.scene`` not None)
    scene_used: int = 0  # of them, those whose verdict it weighed
    # processing time as a histogram of 0.1 ms bins: constant memory however long the run
    ms_hist: np.ndarray = field(default_factory=lambda: np.zeros(BINS, np.int64))

    def add(self, res: Result) -> None:
        cap = res.capture
        self.frames += 1
        self.flagged += res.flagged
        self.ms_hist[min(int(res.seconds * 1e4), BINS - 1)] += 1
        if res.scene is not None:
            self.scene_judged += 1
            self.scene_used += res.scene
        if cap.interfered is None:
            return
        self.truth_known += 1
        self.interfered += cap.interfered
        self.true_flags += res.flagged and cap.interfered
        if cap.interfered and cap.clean is not None:
            valid = cap.clean > 0
            s = 1.0 / cap.scale
            y = cap.clean[valid].astype(np.float64) * s
            self.se_before += float(((cap.frame.depth[valid] * s - y) ** 2).sum())
            self.se_after += float(((res.depth[valid] * s - y) ** 2).sum())
            self.n_valid += int(valid.sum())

    def merge(self, other: RunStats) -> RunStats:
        out = RunStats()
        for k in (
            "frames",
            "flagged",
            "interfered",
            "true_flags",
            "truth_known",
            "n_valid",
            "scene_judged",
            "scene_used",
        ):
            setattr(out, k, getattr(self, k) + getattr(other, k))
        out.se_before, out.se_after = self.se_before + other.se_before, self.se_after + other.se_after
        out.ms_hist = self.ms_hist + other.ms_hist
        return out

    def summary(self) -> dict[str, Any]:
        out: dict[str, Any] = {"frames": self.frames, "flagged": self.flagged}
        if self.frames:
            half = np.searchsorted(np.cumsum(self.ms_hist), (self.frames + 1) / 2)
            ms = (half + 0.5) / 10
            out["ms_median"] = round(float(ms), 2)
            out["fps"] = round(1000 / ms, 1)
        if self.scene_judged:  # the share of frames the sensor's scene weighed (it held still)
            out["scene_used"] = round(self.scene_used / self.frames, 4)
        if self.truth_known:
            out["interfered"] = self.interfered
            out["interfered_of"] = self.truth_known
            out["interfered_ratio"] = round(self.interfered / self.truth_known, 4)
            out["precision"] = round(self.true_flags / self.flagged, 4) if self.flagged else None
            out["recall"] = round(self.true_flags / self.interfered, 4) if self.interfered else None
        if self.n_valid:
            out["rmse_before_cm"] = round(100 * float(np.sqrt(self.se_before / self.n_valid)), 2)
            out["rmse_after_cm"] = round(100 * float(np.sqrt(self.se_after / self.n_valid)), 2)
        return out


COLUMNS = {
    "frames": "frames",
    "interfered": "interfered",
    "flagged": "flagged",
    "precision": "P",
    "recall": "R",
    "rmse_before_cm": "RMSE in (cm)",
    "rmse_after_cm": "RMSE out (cm)",
    "scene_used": "scene",
    "ms_median": "ms/frame",
}


def stats_table(summary: dict[str, Any], title: str) -> Table:
    """A run's summary as a table: one row per sensor (when several) and all together."""
    cols = list(COLUMNS)
    t = Table(title=title)
    t.add_column("sensor")
    for c in cols:
        t.add_column(COLUMNS[c], justify="right")
    rows = [(str(i), s) for i, s in enumerate(summary["sensors"])] if len(summary["sensors"]) > 1 else []
    for name, s in [*rows, ("all", summary["all"])]:
        t.add_row(name, *(_cell(s, c) for c in cols))
    return t


def _cell(s: dict[str, Any], column: str) -> str:
    """A summary's figure as the table shows it: interfered frames as a count of those with truth (as the
    demo's table does), the rest as they are."""
    if s.get(column) is None:
        return NA
    if column == "interfered" and s.get("interfered_of") is not None:
        return f"{s['interfered']}/{s['interfered_of']}"
    return str(s[column])


def median_p99_ms(seconds: list[float]) -> tuple[float, float]:
    """Median and 99th percentile (nearest rank) of durations, in ms; NaN for none."""
    ms = sorted(x * 1e3 for x in seconds)
    if not ms:
        return float("nan"), float("nan")
    return statistics.median(ms), ms[min(len(ms) - 1, int(0.99 * len(ms)))]
