"""Benchmarks (timed in the process; machines are shared, so report medians of repeats)."""

from __future__ import annotations

import platform
import statistics
import time
from collections.abc import Callable

import numpy as np

from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.timing import TimingConfig, simulate

__all__ = ["bench_timing"]


def bench_timing(
    sensors: int = 1000,
    seconds: float = 600.0,
    repeats: int = 3,
    seed: int = 0,
    fps: int = 6,
    progress: Callable[[float], None] | None = None,
) -> dict:
    """The warehouse: ``sensors`` sensors (20% on robots, ~3 neighbours each) for ``seconds`` seconds."""
    t = time.perf_counter()
    graph = OverlapGraph.warehouse(sensors, seconds, seed=seed, neighbours=3.0)
    build_s = time.perf_counter() - t
    cfg = TimingConfig(active_frames=fps)
    times, ratio = [], 0.0
    for r in range(repeats):
        t = time.perf_counter()
        report = None if progress is None else (lambda f, r=r: progress((r + f) / repeats))
        run = simulate(graph, DEFAULT_CONTROLLER, cfg, seconds, seed=seed + r, progress=report)
        times.append(time.perf_counter() - t)
        ratio = run.ratio()
    degree = np.bincount(graph.dst, minlength=sensors)
    return {
        "benchmark": "timing_world_warehouse",
        "sensors": sensors,
        "simulated_s": seconds,
        "edges_directed": int(graph.src.size),
        "mean_live_degree": float(degree.mean() if graph.live is None else graph.live.mean() * degree.mean()),
        "graph_build_s": round(build_s, 3),
        "run_s_median": round(statistics.median(times), 3),
        "run_s_all": [round(x, 3) for x in times],
        "realtime_factor": round(seconds / statistics.median(times), 1),
        "interference_ratio": round(ratio, 4),
        "controller": DEFAULT_CONTROLLER,
        "fps": fps,
        "machine": f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}",
    }


def bench_simulate(frames: int = 1000, repeats: int = 3, workers: int = 2, seed: int = 0) -> dict:
    """Seconds to write ``frames`` simulated 640x480 frames (depth, clean and mask PNGs per frame) with
    ``d2sr simulate``'s code path: 2 sensors at 25 fps in one room, static offsets."""
    import tempfile
    from pathlib import Path

    from d2sr.sim.record import record
    from d2sr.sim.world import make_rig

    rig = make_rig(seed, 2, people=2)
    seconds = frames / (2 * 25)
    times, written = [], 0
    for r in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            summary = record(rig, Path(tmp) / "sim", seconds, 25, "static", seed + r, workers=workers)
            times.append(time.perf_counter() - t0)
            written = summary["frames"]
    med = float(np.median(times))
    return {
        "benchmark": "simulate 640x480 (depth + clean + mask PNG per frame)",
        "frames": written,
        "workers": workers,
        "seconds_median": round(med, 2),
        "seconds_runs": [round(t, 2) for t in times],
        "seconds_per_1000_frames": round(med * 1000 / max(written, 1), 2),
        "bar_seconds_per_1000_frames": 60.0,
    }
