"""Soak: 100,000 simulated frames through the closed loop, resident memory sampled as it goes. Bar: the
resident size grows less than 5% after warm-up (the first 10% of frames).

Three sensors share a timing-only room (the world decides each frame's interference from the sensors'
actual windows); each delivered frame's pixels come from a pool of simulated 320x240 frames, clean or
interfered as the world says, so the models, controllers, buffers and statistics all run for real at a
pace a soak can afford. The sensors run their full 30 frames a second (every frame is delivered) under the
default controller.

Run:  .venv/bin/python bench/soak.py --json docs/results/soak.json
"""

from __future__ import annotations

import argparse
import resource
import time

from d2sr.atomic import write_result
from d2sr.desync import DEFAULT_CONTROLLER, make_controller
from d2sr.eval.speed import frame_4000
from d2sr.frames import Frame
from d2sr.jobs.sources import RoomTrigger
from d2sr.jobs.stats import RunStats
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import RunSettings
from d2sr.sim.dataset import TEST_SEED
from d2sr.sim.lockstep import SimRoom
from d2sr.sim.timing import TimingSettings
from d2sr.sim.world import make_rig
from harness import check_output, output_args


def rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100_000)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    pool = {
        flag: [frame_4000(TEST_SEED + 70_000 + 2 * i + flag, bool(flag))[::2, ::2].copy() for i in range(6)]
        for flag in (0, 1)
    }
    sensors = 3
    cfg = TimingSettings(active_frames=10)
    seconds = args.frames / (sensors * cfg.active_frames) + 1
    room = SimRoom(make_rig(0, sensors=sensors), cfg, seed=0, seconds=2.0, render=False)
    net = open_backend(RunSettings(model="unet8", backend="onnx", threads=1))
    loops = [
        SensorLoop(
            net, make_controller(DEFAULT_CONTROLLER, 30, cfg.active_frames, seed=i), RoomTrigger(room, i)
        )
        for i in range(sensors)
    ]
    stats = [RunStats() for _ in range(sensors)]
    samples, n, t0 = [], 0, time.perf_counter()
    every = max(args.frames // 50, 1)
    for ev in room.slots(seconds):
        if ev.frame is not None and n < args.frames:
            bad = ev.frame.interfered
            img = pool[int(bad)][ev.slot % 6]
            cap = Capture(Frame(f"{ev.slot:07d}", img), 4000.0, ev.slot % 30, interfered=bad)
            stats[ev.sensor].add(loops[ev.sensor].process(cap))
            n += 1
            if n % every == 0:
                samples.append((n, round(rss_mb(), 2)))
                print(f"{n} frames, {samples[-1][1]} MB, {time.perf_counter() - t0:.0f} s", flush=True)
        if ev.period_end:
            loops[ev.sensor].end_period()
        if n >= args.frames:
            break
    warm = [m for k, m in samples if k > args.frames // 10]
    growth = (max(warm) - warm[0]) / warm[0]
    total = stats[0].merge(stats[1]).merge(stats[2]).summary()
    result = {
        "benchmark": "soak: closed loop, 3 sensors, 320x240, onnxruntime UNet8",
        "frames": n,
        "seconds": round(time.perf_counter() - t0, 1),
        "rss_mb_after_warmup": warm[0],
        "rss_mb_max": max(warm),
        "growth_after_warmup": round(growth, 4),
        "bar_growth": 0.05,
        "samples": samples,
        "run": total,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
