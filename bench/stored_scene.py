"""A stored scene (``d2sr scene learn``, ``--scene-from``): how long a 640x480 scene file takes to load, and
the CPU a clean frame costs judged against it (``d2sr detect --scene-from``: the detector, the scene and the
loop, no repair) beside today's scene primed on the frames, measured in the same run.

The frames are a still sensor's: one generated 640x480 L515 room (4000 units per metre) with the sensor's
own noise (3 mm) and dropouts (5% of the pixels each frame), every frame its own draw; the scene is learned
from 16 of them, the loop judges 60 others. CPU time is the process's over all its threads; medians of
``--runs`` passes.

Run:  .venv/bin/python bench/stored_scene.py --json docs/results/bench_stored_scene.json
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from d2sr.atomic import write_result
from d2sr.desync import make_controller
from d2sr.eval.speed import frame_4000
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import RunSettings
from d2sr.scene.stored import StoredScene, learn_scene
from harness import check_output, output_args

SCALE = 4000.0
SEED = 9_200_000


def still_frames(n: int, seed: int) -> list[np.ndarray]:
    """``n`` frames of one still room, each with its own noise and dropouts."""
    base = frame_4000(SEED, False).astype(np.float64)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        f = base + rng.normal(0, 0.003 * SCALE, base.shape)
        f[(rng.random(base.shape) < 0.05) | (base == 0)] = 0
        out.append(np.clip(np.rint(f), 0, 65535).astype(np.uint16))
    return out


def cpu_per_frame(frames: list[np.ndarray], scene: Path | None) -> float:
    """CPU milliseconds a frame through the loop (``repair="none"``), with the stored scene or primed."""
    net = open_backend(RunSettings(backend="onnx"), recovery=False)
    loop = SensorLoop(
        net, make_controller("static", 30, 30), settings=RunSettings(repair="none", scene_from=scene)
    )
    caps = [Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames)]
    if scene is None:
        caps = list(loop.primed(caps))
    for c in caps[:10]:  # warm: the models' first runs, the scene's gate
        loop.process(c)
    t = time.process_time()
    for c in caps[10:]:
        loop.process(c)
    return 1000 * (time.process_time() - t) / (len(caps) - 10)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    learn, judged = still_frames(16, 1), still_frames(60, 2)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "room.npz"
        learn_scene(lambda: iter(learn), SCALE, "bench", len(learn)).save(path)
        loads = []
        for _ in range(20):
            t = time.perf_counter()
            StoredScene.load(path)
            loads.append(1000 * (time.perf_counter() - t))
        stored, primed = [], []
        for _ in range(args.runs):
            stored.append(cpu_per_frame(judged, path))
            primed.append(cpu_per_frame(judged, None))
        size = path.stat().st_size
    s, p = statistics.median(stored), statistics.median(primed)
    result = {
        "frames": "a generated 640x480 L515 room, 3 mm noise and 5% dropouts a frame; 16 learned, 60 judged",
        "file_bytes": size,
        "load_ms": {"median": round(statistics.median(loads), 2), "max": round(max(loads), 2)},
        "cpu_ms_per_clean_frame": {"stored scene": round(s, 2), "primed scene": round(p, 2)},
        "ratio_stored_to_primed": round(s / p, 3),
        "runs": args.runs,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
