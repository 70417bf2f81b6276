"""Benchmark (issue 66): the least time one interfered 640x480 frame can spend in the ROS 2 node on this
machine, with nothing else running: each frame judged (``Pipeline.decide``) and then repaired
(``Pipeline.finish``) on one thread, as the node does for one frame, one frame at a time, the onnxruntime
threads the node gives each worker. Real L515 dev1 frames, every one with outside interference
(``bench.outside``'s ``outside_interference``, a draw of its own each, as ``lab.ros2_loopback --every``); the medians
of the flagged frames (those the node repairs) over ``--frames`` after ``--warm`` warm-up frames, and of the
recovery model's runs alone (``OnnxBackend.raw``: one pass).

With ``--clean`` the same frames as the camera gave them (no interference): the medians of every frame, judged
and (where flagged) repaired, the cost of a typical clean frame.

Run:  python -m lab.frame_latency --data ../shared/data --json docs/results/frame_latency.json
      python -m lab.frame_latency --data ../shared/data --passes 1 --json docs/results/frame_latency_passes1.json
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets_a_i import outside_interference

from d2sr.atomic import write_result
from d2sr.jobs.memory import reuse_freed_memory
from d2sr.runtime.pipeline import Pipeline
from d2sr.runtime.workers import repair_workers


def _ms(values: list[float]) -> float:
    return round(1000 * statistics.median(values), 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--passes", type=int, default=None, help="the node's --passes (default: its own)")
    ap.add_argument("--model", default=None, help="the node's --model (default: its own)")
    ap.add_argument("--models", type=Path, default=None, help="the node's --models (default: the shipped)")
    ap.add_argument(
        "--clean", action="store_true", help="the frames as the camera gave them: every frame timed"
    )
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    files = sorted((args.data / "l515" / "dev1").glob("*.png"))[:40]
    if len(files) < 40:
        raise SystemExit(f"{args.data}/l515/dev1: needs 40 frames, found {len(files)}")
    clean = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files]
    n = args.warm + args.frames
    if args.clean:
        sent = [clean[k % len(clean)] for k in range(n)]
    else:
        sent = [outside_interference(clean[k % len(clean)], 4000.0, 7 + k) for k in range(n)]
    _, threads = repair_workers()
    reuse_freed_memory()  # as the node does (d2sr.ros2.serve)
    decide, finish, total = [], [], []
    passes: list[float] = []
    flagged = 0
    given = {"passes": args.passes, "model": args.model, "models": args.models}
    extra = {k: v for k, v in given.items() if v is not None}
    with Pipeline(4000.0, threads=threads, **extra) as pipe:
        # The model that repairs: auto's temporal one, or the one model named.
        repairer = getattr(pipe.backend, "temporal", pipe.backend)
        raw = repairer.raw

        def timed(metres: np.ndarray, previous: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
            t = time.perf_counter()
            out = raw(metres, previous)
            passes.append(time.perf_counter() - t)
            return out

        for k, frame in enumerate(sent):
            counted = k >= args.warm
            if counted:
                repairer.raw = timed  # the instance's, so the passes are timed where they run
            t0 = time.perf_counter()
            d = pipe.decide(frame)
            t1 = time.perf_counter()
            r = pipe.finish(d)
            t2 = time.perf_counter()
            flagged += int(counted and r.interfered)
            if counted and (r.interfered or args.clean):
                decide.append(t1 - t0)
                finish.append(t2 - t1)
                total.append(t2 - t0)
    result = {
        "data": "L515 dev1 (real captures), "
        + (
            "as the camera gave them"
            if args.clean
            else "every frame with outside interference (bench/outside)"
        ),
        "frames": args.frames,
        "timed": "every frame" if args.clean else "the flagged frames",
        "flagged": flagged,
        "onnxruntime_threads": threads or 1,
        "passes": args.passes or "the default",
        "model": args.model or "the default",
        "median_ms": {
            "judged (decide)": _ms(decide),
            "repaired (finish)": _ms(finish),
            "both": _ms(total),
            "one recovery pass": _ms(passes) if passes else None,
        },
        "recovery_passes_per_flagged_frame": round(len(passes) / max(flagged, 1), 2),
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
