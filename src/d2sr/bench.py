"""Benchmarks (timed in the process; machines are shared, so report medians of repeats)."""

from __future__ import annotations

import json
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.timing import TimingConfig, simulate

__all__ = ["bench_models", "bench_simulate", "bench_timing", "write_result"]


def write_result(result: dict, path: Path | None) -> str:
    """The result as JSON text, also written atomically to ``path`` when given."""
    from d2sr.atomic import atomic_write

    text = json.dumps(result, indent=1)
    if path is not None:
        atomic_write(path, text + "\n")
    return text


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


def _median_ms(fn: Callable[[], object], repeats: int, warmup: int = 3) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def _weights_with_onnx(names: list[str], tmp: str) -> Path:
    """The shipped weights folder when it has every model as ONNX and safetensors; otherwise random-weight
    copies in ``tmp`` (speed does not depend on the weights' values)."""
    from d2sr.runtime.backends import WEIGHTS

    if all((WEIGHTS / f"{n}.onnx").is_file() and (WEIGHTS / f"{n}.safetensors").is_file() for n in names):
        return WEIGHTS
    from d2sr.export import export
    from d2sr.models import build
    from d2sr.models.weights import save_model

    root = Path(tmp)
    for n in names:
        save_model(build(n).eval(), n, root / f"{n}.safetensors")
        export(root / f"{n}.safetensors", root / f"{n}.onnx", check=False)
    return root


def bench_models(
    models: tuple[str, ...] = ("unet8", "unet16", "unet32", "paper-unet8"),
    repeats: int = 30,
    threads: int = 2,
    outside: bool = True,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Frames per second at 640x480, batch 1, of the detector, each UNet, and detect + repair (UNet8, every
    frame repaired), for torch and onnxruntime; and ``d2sr recover --all`` timed from outside the process
    (60 frames minus 10 frames, so start-up and model loading cancel out)."""
    import tempfile

    import torch

    from d2sr.models.inference import TorchBackend
    from d2sr.runtime.backends import WEIGHTS, Backend, OnnxBackend, to_depth_units
    from d2sr.train.synth import synth_frame

    torch.set_num_threads(threads)
    frame, _ = synth_frame(1_000_001, interfered=True)
    metres = (frame.astype(np.float32) / np.float32(4000))[None]
    out: dict = {"resolution": "640x480", "batch": 1, "threads": threads, "repeats": repeats, "fps": {}}
    with tempfile.TemporaryDirectory() as tmp:
        wdir = _weights_with_onnx(["detector", "paper-detector", *models], tmp)
        out["weights"] = "shipped" if wdir == WEIGHTS else "random (no shipped ONNX found)"

        def load(backend: str, detector: str, model: str | None) -> Backend:
            if backend == "onnxruntime":
                return OnnxBackend(wdir / f"{detector}.onnx", model and wdir / f"{model}.onnx", threads)
            return TorchBackend(wdir / f"{detector}.safetensors", model and wdir / f"{model}.safetensors")

        def fps_of(fn: Callable[[], object]) -> float:
            return round(1000 / _median_ms(fn, repeats), 1)

        for backend in ("onnxruntime", "torch"):
            fps = out["fps"][backend] = {}
            for det in ("detector", "paper-detector"):
                d = load(backend, det, None)
                fps[det] = fps_of(lambda d=d: d.scores(metres))
            for m in models:
                if progress:
                    progress(f"{backend} {m}")
                net = load(backend, "detector", m)

                def both(net: Backend = net) -> None:
                    net.scores(metres)
                    pred, mask = net.recover(metres)
                    to_depth_units(frame, pred[0], mask[0], 4000.0)

                fps[m] = fps_of(lambda net=net: net.recover(metres))
                fps[f"detect+{m}"] = fps_of(both)
        if outside:
            if progress:
                progress("d2sr recover --all, from outside")
            out["outside"] = _outside(wdir, frame)
    out["bars"] = {"detector_fps": 300, "detect+unet8_fps": 30}
    return out


def _outside(wdir: object, frame: np.ndarray, runs: int = 3) -> dict:
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    from d2sr.frames.png import encode_png, write_meta

    def run(folder: Path, dest: Path) -> float:
        t = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "d2sr",
                "recover",
                str(folder),
                "--out",
                str(dest),
                "--all",
                "--weights",
                str(wdir),
                "--backend",
                "onnx",
            ],
            check=True,
            capture_output=True,
        )
        return time.perf_counter() - t

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for n in (10, 60):
            (root / f"in{n}").mkdir()
            for i in range(n):
                (root / f"in{n}" / f"{i:04d}.png").write_bytes(encode_png(frame, "bench"))
            write_meta(root / f"in{n}", 4000.0, None, [])
        t10 = [run(root / "in10", root / "o10") for _ in range(runs)]
        t60 = [run(root / "in60", root / "o60") for _ in range(runs)]
    per = (statistics.median(t60) - statistics.median(t10)) / 50
    return {
        "command": "d2sr recover IN --out OUT --all --backend onnx (60 frames vs 10)",
        "seconds_10": [round(t, 3) for t in t10],
        "seconds_60": [round(t, 3) for t in t60],
        "fps": round(1 / per, 1) if per > 0 else None,
    }
