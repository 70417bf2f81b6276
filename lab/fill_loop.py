"""Benchmark (issue 43, speed): full frame rate inside the loop. ``d2sr.Pipeline`` runs a sensor whose laser
is on in its window only: each slot in ``Pipeline.window`` gets the camera's real frame (detected, repaired
when flagged, its colour kept), every other slot is synthesized from the colour frame
(``Pipeline.synthesize``). The real hand-held D435 RGB-D sequence (``../shared/data/d435``), decoded into
memory first: no file I/O, as from a live camera. Reports frames out per second (wall, and CPU over all
threads) for 6 and 15 active of 30, and the synthesized frames' RMSE against the real frames they stand for
(the same pooling as ``lab/fill_d435.py``), so that the speed is of the same output. Bar: 30 frames a
second at 640x480 on 2 cores.

Run:  python -m lab.fill_loop --data ../shared/data --json docs/results/fill_loop.json
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import used_models

from d2sr.atomic import write_result
from d2sr.desync import TOTAL_FRAMES
from d2sr.runtime.pipeline import Pipeline
from lab.fill_eval import PooledError

FAR_MM = 8000


def once(
    depth: list[np.ndarray], colour: list[np.ndarray], active: int
) -> tuple[float, float, PooledError, int]:
    """One pass over the sequence: (wall s, CPU s, synthesized frames' errors, frames synthesized)."""
    pipe = Pipeline(1000.0, active_frames=active)
    errors, made = PooledError(1000, FAR_MM), 0
    c, t = time.process_time(), time.perf_counter()
    for i, (d, rgb) in enumerate(zip(depth, colour, strict=True)):
        slot = i % TOTAL_FRAMES
        if i == 0 or pipe.window.active(slot):
            pipe.process(d, slot=slot, colour=rgb)
            continue
        s = pipe.synthesize(rgb)
        errors.add(s.depth.astype(np.float64), d.astype(np.float64))
        made += 1
    return time.perf_counter() - t, time.process_time() - c, errors, made


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--repeats", type=int, default=3, help="passes over the sequence per setting (median)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    seq = args.data / "d435"
    files = sorted(seq.glob("depth*.png"))
    colours = sorted((seq / "rgb").iterdir())
    if not files or len(colours) < len(files):
        raise SystemExit(f"{seq}: needs depth*.png and as many rgb/ frames")
    depth = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files]
    colour = [cv2.imread(str(f), cv2.IMREAD_COLOR) for f in colours[: len(files)]]
    once(depth[:40], colour[:40], 6)  # warm-up: the sessions' first runs
    runs = []
    for active in (15, 6):
        walls, cpus = [], []
        for _ in range(args.repeats):
            wall, cpu, errors, made = once(depth, colour, active)
            walls.append(wall)
            cpus.append(cpu)
        n = len(files)
        runs.append(
            {
                "active_frames": active,
                "frames_out": n,
                "synthesized": made,
                "frames_per_second": round(n / statistics.median(walls), 1),
                "cpu_ms_per_frame_out": round(1000 * statistics.median(cpus) / n, 2),
                "synthesized_rmse_cm": errors.rmse_cm(),
                "synthesized_coverage": errors.coverage(),
            }
        )
    result = {
        "benchmark": "issue 43: frames out a second from d2sr.Pipeline, real frames in the window and the "
        "others synthesized from colour, in memory (no file I/O)",
        "size": f"{depth[0].shape[1]}x{depth[0].shape[0]}",
        "repeats": args.repeats,
        "bar_frames_per_second": 30,
        "runs": runs,
    }
    data = f"{seq} ({len(files)} frames, hand-held D435, depth aligned to colour; development sequence)"
    print(write_result(result, args.json, models=used_models(None), data=data))


if __name__ == "__main__":
    main()
