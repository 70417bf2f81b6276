"""``d2sr bench``: speed and memory benchmarks (timed in the process; machines are shared, so report
medians of repeats)."""

from __future__ import annotations

import functools
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.desync import DEFAULT_CONTROLLER, TOTAL_FRAMES
from d2sr.errors import D2SRError
from d2sr.provenance import cpu
from d2sr.runtime.settings import RunSettings
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.timing import TimingSettings, simulate

__all__ = [
    "bench_models",
    "bench_pipeline",
    "bench_simulate",
    "bench_timing",
    "bench_typical",
    "bench_worst",
    "cpu",
]


def frame_4000(seed: int, interfered: bool) -> np.ndarray:
    """A generated frame in the L515's units (4000 per metre), whatever sensor kind drew it."""
    from d2sr.sim.dataset import synth_frame

    frame, _, scale = synth_frame(seed, interfered)
    return np.clip(np.rint(frame.astype(np.float64) * (4000 / scale)), 0, 65535).astype(np.uint16)


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
    cfg = TimingSettings(active_frames=fps)
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

    from d2sr.sim.record import RecordSettings, record
    from d2sr.sim.world import make_rig

    rig = make_rig(seed, 2, people=2)
    seconds = frames / (2 * 25)
    times, written = [], 0
    for r in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            plan = RecordSettings(seconds=seconds, active_frames=25, seed=seed + r, workers=workers)
            summary = record(rig, Path(tmp) / "sim", plan)
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


def _weights_with_onnx(names: list[str], tmp: str) -> tuple[Path, dict[str, str]]:
    """A folder with every model as ONNX and safetensors: the shipped files where they exist (a repair's
    passes depend on what the first one finds, so speed depends on the weights), random-weight ones for
    the rest; and which each is."""
    import shutil

    from d2sr.contract.catalog import WEIGHTS, model_files
    from d2sr.models import build
    from d2sr.models.onnx.export import export
    from d2sr.models.store import save_model

    root, kinds = Path(tmp), {}
    for n in names:
        files = model_files(WEIGHTS, n)  # thresholds are in their metadata
        if {f.suffix for f in files} == {".onnx", ".safetensors"}:
            for f in files:
                shutil.copy(f, root / f.name)
            kinds[n] = "shipped"
        else:
            save_model(build(n).eval(), n, root / f"{n}.safetensors")
            export(root / f"{n}.safetensors", root / f"{n}.onnx", check=False)
            kinds[n] = "random (not shipped)"
    return root, kinds


def bench_models(
    models: tuple[str, ...] = ("unet8", "unet8-fast", "unet16", "unet32", "paper-unet8"),
    repeats: int = 30,
    threads: int = 2,
    outside: bool = True,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Frames per second at 640x480, batch 1, of the detector, each UNet (one forward pass, and ``recover``
    with its own passes on an interfered frame), and detect + repair (every frame repaired), for torch and
    onnxruntime; each UNet's one pass on one onnxruntime thread beside unet8's (the models alternate, so a
    busy machine slows all alike); and ``d2sr recover --repair all`` timed from outside the process (60
    frames minus 10 frames, so start-up and model loading cancel out)."""
    import tempfile

    import torch

    from d2sr.contract.catalog import CATALOG
    from d2sr.contract.repair import repair_frame
    from d2sr.models.inference import TorchBackend
    from d2sr.runtime.backends import Backend, OnnxBackend

    torch.set_num_threads(threads)
    frame = frame_4000(1_000_001, interfered=True)
    metres = (frame.astype(np.float32) / np.float32(4000))[None]
    out: dict = {"resolution": "640x480", "batch": 1, "threads": threads, "repeats": repeats, "fps": {}}
    # at most, in "<model> recover" and "detect+<model>": each model's own
    out["recovery_passes"] = {m: CATALOG[m].passes for m in models}
    with tempfile.TemporaryDirectory() as tmp:
        wdir, out["weights"] = _weights_with_onnx(["detector", "paper-detector", *models], tmp)

        def load(backend: str, detector: str, model: str | None) -> Backend:
            passes = CATALOG[model].passes if model else 1
            if backend == "onnxruntime":
                rec = wdir / f"{model}.onnx" if model else None
                return OnnxBackend(wdir / f"{detector}.onnx", rec, threads, passes=passes)
            rec_weights = wdir / f"{model}.safetensors" if model else None
            return TorchBackend(wdir / f"{detector}.safetensors", rec_weights, passes=passes)

        def fps_of(fn: Callable[[], object]) -> float:
            return round(1000 / _median_ms(fn, repeats), 1)

        for backend in ("onnxruntime", "torch"):
            fps = out["fps"][backend] = {}
            for det in ("detector", "paper-detector"):
                d = load(backend, det, None)
                fps[det] = fps_of(functools.partial(d.scores, metres))
            for m in models:
                if progress:
                    progress(f"{backend} {m}")
                net = load(backend, "detector", m)

                def both(net: Backend = net) -> None:
                    net.scores(metres)
                    pred, mask = net.recover(metres)
                    repair_frame(frame, pred[0], mask[0], 4000.0)

                fps[m] = fps_of(functools.partial(net.raw, metres))  # one forward pass (paper Table III)
                fps[f"{m} recover"] = fps_of(functools.partial(net.recover, metres))  # its passes included
                fps[f"detect+{m}"] = fps_of(both)
        out["one_thread"] = _one_thread(wdir, models, metres, repeats)
        if outside:
            if progress:
                progress("d2sr recover --repair all, from outside")
            out["outside"] = _outside(
                [
                    "recover",
                    "--repair",
                    "all",
                    "--no-report",
                    "--models",
                    str(wdir),
                    "--backend",
                    "onnx",
                    "--depth-scale",
                    "4000",
                ],
                [frame],
            )
    out["bars"] = {"detector_fps": 300, "detect+unet8_fps": 30}
    return out


def _one_thread(wdir: Path, models: tuple[str, ...], metres: np.ndarray, repeats: int) -> dict:
    """Each recovery model's one pass on one onnxruntime thread (ms, median), the models taking turns, and
    its share of unet8's (issue 78's bar for unet8-fast: at most 0.25)."""
    from d2sr.runtime.backends import OnnxBackend

    nets = {m: OnnxBackend(None, wdir / f"{m}.onnx", 1) for m in models}
    for net in nets.values():
        net.raw(metres)
    times: dict[str, list[float]] = {m: [] for m in models}
    for _ in range(repeats):
        for m, net in nets.items():
            t = time.perf_counter()
            net.raw(metres)
            times[m].append(1000 * (time.perf_counter() - t))
    ms = {m: round(statistics.median(t), 2) for m, t in times.items()}
    out: dict = {"ms_one_pass": ms}
    if "unet8" in ms:
        out["share_of_unet8"] = {m: round(v / ms["unet8"], 3) for m, v in ms.items()}
    return out


def _recording(folder: Path, frames: list[np.ndarray], scale: float) -> None:
    """Write ``frames`` as a d2sr PNG recording (0000.png, ... and its depth scale) in a new ``folder``."""
    from d2sr.frames.png import encode_png, write_meta

    folder.mkdir()
    for i, img in enumerate(frames):
        (folder / f"{i:04d}.png").write_bytes(encode_png(img, "bench"))
    write_meta(folder, scale, None, [])


def _outside(command: list[str], frames: list[np.ndarray], runs: int = 3) -> dict:
    """Time ``d2sr <command> IN --out OUT`` on 60 frames and on 10 from outside the process; the
    difference over 50 frames is the per-frame cost without start-up. Also the peak resident memory."""
    import resource
    import subprocess
    import sys
    import tempfile

    def run(folder: Path, dest: Path) -> float:
        t = time.perf_counter()
        cmd = [sys.executable, "-m", "d2sr", command[0], str(folder), "--out", str(dest), *command[1:]]
        subprocess.run(cmd, check=True, capture_output=True)
        return time.perf_counter() - t

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for n in (10, 60):
            _recording(root / f"in{n}", [frames[i % len(frames)] for i in range(n)], 4000.0)
        t10 = [run(root / "in10", root / f"o10_{k}") for k in range(runs)]
        t60 = [run(root / "in60", root / f"o60_{k}") for k in range(runs)]
    per = (statistics.median(t60) - statistics.median(t10)) / 50
    return {
        "measured": f"d2sr {command[0]} IN --out OUT {' '.join(command[1:])} (60 frames vs 10)",
        "seconds_10": [round(t, 3) for t in t10],
        "seconds_60": [round(t, 3) for t in t60],
        "fps": round(1 / per, 1) if per > 0 else None,
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024, 1),
    }


def bench_pipeline(
    frames: int = 60,
    repeats: int = 3,
    threads: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """The runtime loop (detect, buffer, controller, repair) at 640x480 and 320x240 with 0%, 50% and 100%
    of frames interfered, the worst case (every frame repaired), the controller's share of a frame's
    time, peak memory, and ``d2sr run --repair all`` from outside the process."""
    import resource

    from d2sr.desync import make_controller
    from d2sr.frames import Frame
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.loop import Capture, SensorLoop
    from d2sr.sim.dataset import TEST_SEED

    say = progress or (lambda s: None)
    net = open_backend(RunSettings(model="unet8", backend="onnx", threads=threads))
    say("generating frames")
    clean = [frame_4000(TEST_SEED + 50_000 + i, interfered=False) for i in range(8)]
    bad = [frame_4000(TEST_SEED + 60_000 + i, interfered=True) for i in range(8)]
    rows = []
    worst_640 = None
    for h, w in ((480, 640), (240, 320)):
        step = 480 // h
        for share, repair in ((0.0, "flagged"), (0.5, "flagged"), (1.0, "flagged"), (1.0, "all")):
            say(f"pipeline {w}x{h}, {share:.0%} interfered, repair {repair}")
            seq = [
                (bad if (i * share) % 1 + share >= 1 else clean)[i % 8][::step, ::step].copy()
                for i in range(frames)
            ]
            per_frame, flagged = [], 0
            for _ in range(repeats):
                loop = SensorLoop(
                    net,
                    make_controller(DEFAULT_CONTROLLER, TOTAL_FRAMES, 15, seed=0),
                    settings=RunSettings(repair=repair, scene=False),
                )
                for d in seq[:3]:  # warm-up
                    loop.process(Capture(Frame("w", d), 4000.0))
                t = time.perf_counter()
                flagged = 0
                for i, d in enumerate(seq):
                    flagged += loop.process(Capture(Frame(f"{i}", d), 4000.0)).flagged
                per_frame.append((time.perf_counter() - t) / frames)
            med = statistics.median(per_frame)
            rows.append(
                {
                    "size": f"{w}x{h}",
                    "interfered": share,
                    "repair": repair,
                    "flagged": round(flagged / frames, 3),
                    "ms_per_frame": round(1000 * med, 2),
                    "fps": round(1 / med, 1),
                }
            )
            if (h, repair) == (480, "all"):
                worst_640 = med
    # The controller and the flag buffer alone, per frame (a loop whose models cost nothing).
    say("controller overhead")
    loop = SensorLoop(
        net,
        make_controller(DEFAULT_CONTROLLER, TOTAL_FRAMES, 15, seed=0),
        settings=RunSettings(repair="none", scene=False),
    )
    n = 30_000
    rng = np.random.default_rng(0)
    flags = rng.random(n) < 0.2
    t = time.perf_counter()
    for f in flags:
        loop.replay(bool(f))
    ctrl_s = (time.perf_counter() - t) / n
    say("from outside the process")
    outside = _outside(["run", "--repair", "all", "--backend", "onnx", "--depth-scale", "4000"], bad)
    return {
        "benchmark": "runtime pipeline (onnxruntime, UNet8), in-process medians of repeats",
        "machine": f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}",
        "frames": frames,
        "repeats": repeats,
        "rows": rows,
        "controller_us_per_frame": round(1e6 * ctrl_s, 2),
        "controller_share_of_worst_frame": round(ctrl_s / worst_640, 5) if worst_640 else None,
        "peak_rss_mb_in_process": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "outside": outside,
        "bars": {"worst_case_fps_640x480_outside": 30, "controller_share": 0.01},
    }


def bench_typical(
    frames: list[np.ndarray],
    depth_scale: float,
    repeats: int = 3,
    threads: int | None = None,
    warmup: int = 5,
    settle: int = 0,
    **options: Any,
) -> dict:
    """The typical case (issue 44): CPU time a frame through ``d2sr.Pipeline`` in process, on a sensor's
    clean frames in time order, as shipped (every frame judged, the flagged ones repaired); and with
    ``repair="none"`` (``no repair``), the judging alone: the detector, the scene and the loop. CPU time is
    the process's, over all its threads (``time.process_time``): what the robot's other work loses. Medians
    of ``repeats`` passes over the frames, each with a fresh Pipeline warmed up on ``warmup`` frames, after
    one untimed pass of each mode. ``settle``: the first frames are run untimed first, and only the rest
    timed (a sensor that has run a while: its scene built)."""
    from d2sr.runtime.pipeline import Pipeline

    clocked = frames[settle:]
    if not clocked:
        raise ValueError("bench_typical needs frames to time")
    out: dict = {
        "measured": "d2sr.Pipeline(depth_scale).process(frame), clean frames in order, in process",
        "frames": len(frames),
        "size": f"{frames[0].shape[1]}x{frames[0].shape[0]}",
        "repeats": repeats,
        "warmup_frames": warmup,
        "settle_frames": settle,
        "threads": threads or "default (the detector on one core, the repair on all)",
    }
    if options:
        out["options"] = options
    modes = {"as shipped": "flagged", "no repair": "none"}
    runs: dict[str, dict] = {n: {"cpu": [], "wall": [], "flagged": 0} for n in modes}

    def once(name: str, timed: bool) -> None:
        pipe = Pipeline(depth_scale, threads=threads, **(options | {"repair": modes[name]}))
        for f in [*frames[:warmup], *frames[:settle]]:
            pipe.process(f)
        c, t = time.process_time(), time.perf_counter()
        flagged = sum(bool(pipe.process(f).interfered) for f in clocked)
        if timed:
            runs[name]["cpu"].append(1000 * (time.process_time() - c) / len(clocked))
            runs[name]["wall"].append(1000 * (time.perf_counter() - t) / len(clocked))
            runs[name]["flagged"] = flagged

    # One untimed pass of each first: a process's first passes also pay for its sessions' first runs (the
    # first timed pass read 1-3 ms high). Then the modes alternate, so a noisy machine slows both alike.
    for name in modes:
        once(name, timed=False)
    for _ in range(repeats):
        for name in modes:
            once(name, timed=True)
    for name, r in runs.items():
        out[name] = {
            "cpu_ms_per_frame": round(statistics.median(r["cpu"]), 2),
            "wall_ms_per_frame": round(statistics.median(r["wall"]), 2),
            "cpu_ms_runs": [round(v, 2) for v in r["cpu"]],
            "flagged": f"{r['flagged']} of {len(clocked)}",
        }
    out["bar_cpu_ms_per_frame"] = 5.0
    return out


def bench_worst(
    frames: list[np.ndarray], depth_scale: float, runs: int = 5, model: str | None = None
) -> dict:
    """The worst case (issue 44) against its floor, in one run: ``d2sr recover --repair all`` from outside the
    process, timed on all the frames and on 10 (start-up cancels out), and the floor any whole-process tool
    pays: the same frames read and written as 16-bit PNGs by OpenCV alone (its loop timed in its own
    process). The two alternate so that a shared machine slows both alike. ``model``: recover's --model
    [its default]."""
    import subprocess
    import sys
    import tempfile

    n = len(frames)
    if n <= 10:
        raise ValueError("bench_worst needs more than 10 frames")
    floor = (
        "import sys, time, pathlib, cv2\n"
        "src, dst = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])\n"
        "dst.mkdir()\n"
        "files = sorted(src.glob('*.png'))\n"
        "t = time.perf_counter()\n"
        "for f in files:\n"
        "    cv2.imwrite(str(dst / f.name), cv2.imread(str(f), cv2.IMREAD_UNCHANGED))\n"
        "print(time.perf_counter() - t)\n"
    )
    recover = ["-m", "d2sr", "recover", "--repair", "all", "--no-report", "--depth-scale", f"{depth_scale:g}"]
    recover += ["--model", model] if model is not None else []
    chosen = f" --model {model}" if model is not None else ""
    recover.append("--out")

    def run(args: list[str]) -> tuple[float, str]:
        t = time.perf_counter()
        r = subprocess.run([sys.executable, *args], check=True, capture_output=True, text=True)
        return time.perf_counter() - t, r.stdout

    times: dict[str, list[float]] = {"floor loop": [], "recover 10": [], f"recover {n}": []}

    def per_frame() -> float:
        return (statistics.median(times[f"recover {n}"]) - statistics.median(times["recover 10"])) / (n - 10)

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for k in (10, n):
            _recording(root / f"in{k}", frames[:k], depth_scale)
        done = 0
        # Further runs (up to ``runs`` more) while the machine's noise leaves the difference at or below 0:
        # on a loaded machine a short run's start-up once took longer than the whole long run.
        while done < runs or (per_frame() <= 0 and done < 2 * runs):
            times["floor loop"].append(
                float(run(["-c", floor, str(root / f"in{n}"), str(root / f"f{done}")])[1])
            )
            for k in (10, n):
                times[f"recover {k}"].append(
                    run([*recover, str(root / f"r{k}_{done}"), str(root / f"in{k}")])[0]
                )
            done += 1
    rec = per_frame()
    if rec <= 0:
        raise D2SRError(
            f"worst case: {done} runs of {n} frames took no longer than of 10; the machine is too busy"
        )
    png = statistics.median(times["floor loop"]) / n
    return {
        "measured": f"d2sr recover IN --repair all{chosen} --out OUT from outside, {n} frames vs 10; the "
        f"floor: OpenCV reading and writing the {n} PNGs",
        "frames": n,
        "size": f"{frames[0].shape[1]}x{frames[0].shape[0]}",
        "runs": done,
        "seconds": {k: [round(v, 4) for v in t] for k, t in times.items()},
        "recover_ms_per_frame": round(1000 * rec, 2),
        "floor_ms_per_frame": round(1000 * png, 2),
        "recover_fps": round(1 / rec, 1),
        "ratio_to_floor": round(rec / png, 2),
        "bar_ratio_to_floor": 1.5,
    }
