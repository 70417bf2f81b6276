"""Recordings of a simulated multi-sensor room (``d2sr simulate``).

The timing world decides, from every sensor's active window, which frames exist and which lasers
overlapped each of them; the scene model renders the frames; the interference model corrupts the
overlapped ones where the interferers' light lands. Per sensor: ``depth/`` (what the sensor delivers),
``clean/`` (the same frames without interference), ``masks/`` (uint8, 255 = interference), each a PNG
folder with ``meta.json``; ``scene.json`` describes the room, poses, overlap graph and timing.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
from pydantic import Field

from d2sr.atomic import atomic_dir
from d2sr.config import Settings
from d2sr.desync import TOTAL_FRAMES
from d2sr.errors import ConfigError
from d2sr.frames.layout import RECORDING, FrameFolder, sensor_dir
from d2sr.frames.overlap import MAX_WORKERS, processes
from d2sr.sim.interference import InterferenceSettings
from d2sr.sim.lockstep import Camera
from d2sr.sim.rooms import L515, SensorModel
from d2sr.sim.timing import TimingRun, TimingSettings, simulate
from d2sr.sim.world import Rig, overlap_graph

__all__ = [
    "record",
    "render_frames",
    "to_ros2",
]

EPOCH_NS = 1_700_000_000_000_000_000  # timestamps start here (any fixed origin would do)
CHUNK = 40


def render_frames(
    rig: Rig,
    sensor: int,
    slots: np.ndarray,
    run: TimingRun,
    seed: int,
    model: SensorModel,
    cfg: InterferenceSettings,
) -> list[tuple[str, int, np.ndarray, np.ndarray, np.ndarray, list[int]]]:
    """Frames of one sensor at the given slots: (name, timestamp, depth, clean, mask, interferers)."""
    tau = (1.0 + run.drifts[sensor]) / run.config.fps
    cam = Camera(rig, sensor, seed, model, cfg, seed * 1_000_003 + sensor * 10_007 + int(slots[0]))
    out = []
    assert run.frames is not None
    for g in slots:
        t = float(run.phases[sensor] + g * tau)
        srcs = []
        if run.frames[sensor, g] == 2:
            bits = int(run.hits[sensor, g]) if run.hits is not None else 0
            srcs = [j for j in range(rig.n) if bits >> j & 1]
        depth, clean, mask = cam.frame(t, int(g), srcs)
        out.append((f"{int(g):06d}", EPOCH_NS + round(t * 1e9), depth, clean, mask, srcs))
    return out


def _work(args: tuple) -> list[dict]:
    rig, sensor, slots, run, seed, model, cfg, root = args
    rows = []
    folder = FrameFolder(sensor_dir(Path(root), sensor), RECORDING)
    for name, stamp, depth, clean, mask, srcs in render_frames(rig, sensor, slots, run, seed, model, cfg):
        folder.write(name, depth=depth, clean=clean, masks=mask)
        rows.append(
            {
                "name": name,
                "timestamp_ns": stamp,
                "interfered": bool(mask.any()),
                "interferers": srcs,
                "mask_share": round(float(mask.mean()), 5),
            }
        )
    return rows


MAX_SECONDS = 3600.0  # an hour of a room: 108,000 frames a sensor (a trillion seconds asked 11 TB of memory)


class RecordSettings(Settings):
    """How ``record`` runs the simulated room: for ``seconds``, each sensor's laser on ``active_frames`` of
    every 30-slot period under ``controller``, seeded by ``seed``, rendered on ``workers`` processes
    [up to 2]."""

    seconds: float = Field(10.0, gt=0, le=MAX_SECONDS, allow_inf_nan=False)
    active_frames: int = Field(15, ge=1, le=TOTAL_FRAMES)
    controller: str = "static"
    seed: int = 0
    workers: int | None = Field(None, ge=1, le=MAX_WORKERS)


def record(
    rig: Rig,
    out: Path,
    settings: RecordSettings | None = None,
    model: SensorModel = L515,
    progress: Callable[[int, int], None] | None = None,
    finish: Callable[[Path], None] | None = None,
) -> dict:
    """Write the recordings of every sensor of ``rig`` into ``out`` (atomically); returns the summary.
    ``finish`` runs on the complete temporary folder before it is moved into place."""
    rs = settings if settings is not None else RecordSettings()
    seconds, active_frames, controller, seed, workers = (
        rs.seconds, rs.active_frames, rs.controller, rs.seed, rs.workers
    )  # fmt: skip
    cfg = InterferenceSettings()
    tcfg = TimingSettings(fps=30.0, active_frames=active_frames)
    graph = overlap_graph(rig, seconds)
    run = simulate(graph, controller, tcfg, duration_s=seconds, seed=seed, record_frames=True)
    assert run.frames is not None
    jobs = []
    for i in range(rig.n):
        slots = np.flatnonzero(run.frames[i] > 0)
        jobs += [(i, slots[k : k + CHUNK]) for k in range(0, slots.size, CHUNK)]
    total = sum(len(s) for _, s in jobs)
    if total == 0:
        raise ConfigError("the simulated run delivered no frames (too short?)")
    rows: dict[int, list[dict]] = {i: [] for i in range(rig.n)}
    with atomic_dir(out) as tmp:
        for i in range(rig.n):
            FrameFolder(sensor_dir(tmp, i), RECORDING)
        args = [(rig, i, s, run, seed, model, cfg, str(tmp)) for i, s in jobs]
        done = 0
        n_work = workers or min(2, os.cpu_count() or 1)
        if n_work > 1:
            with processes(n_work) as pool:
                for (i, s), got in zip(jobs, pool.map(_work, args), strict=True):
                    rows[i] += got
                    done += len(s)
                    if progress:
                        progress(done, total)
        else:
            for (i, s), a in zip(jobs, args, strict=True):
                rows[i] += _work(a)
                done += len(s)
                if progress:
                    progress(done, total)
        for i in range(rig.n):
            FrameFolder(sensor_dir(tmp, i), RECORDING).finish(model.depth_scale, rig.intr, rows[i])
        summary = {
            "sensors": rig.n,
            "seconds": seconds,
            "active_frames": active_frames,
            "controller": controller,
            "seed": seed,
            "frames": total,
            "interfered_frames": int(sum(r["interfered"] for v in rows.values() for r in v)),
            "depth_scale": model.depth_scale,
            "intrinsics": rig.intr.to_dict(),
            "overlap_edges": [[int(a), int(b)] for a, b in zip(graph.src, graph.dst, strict=True)],
            "room": asdict(rig.room),
            "poses": [asdict(p) for p in rig.poses],
            "moving": [tr is not None for tr in rig.trajectories],
            "sensor_model": model.model_dump(),
            "interference": cfg.model_dump(),
            "timing": tcfg.model_dump(),
        }
        (tmp / "scene.json").write_text(json.dumps(summary, indent=1) + "\n")
        if finish is not None:  # e.g. convert to another format, still before the output appears
            finish(tmp)
    return summary


def to_ros2(out: Path, sensors: int) -> None:
    """Replace each sensor's depth/ PNG folder in a recording by a ROS 2 bag depth_ros2/ (millimetres,
    16UC1); ``record`` calls it on the temporary output, before the recording appears."""
    import shutil

    from d2sr.frames import open_frames, open_writer

    for i in range(sensors):
        src = sensor_dir(out, i) / RECORDING["depth"]
        reader = open_frames(src)
        with open_writer(sensor_dir(out, i) / "depth_ros2", "ros2", 1000.0, reader.intrinsics) as w:
            for f in reader:
                w.write(f)
        shutil.rmtree(src)
