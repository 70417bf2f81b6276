"""Benchmark: what logging a run to Rerun costs. The closed loop of ``d2sr run sim`` (3 sensors, every
frame repaired, 640x480, onnxruntime) with and without ``--rerun FILE.rrd`` (images at every 2nd pixel,
logged on a thread of their own), interleaved runs, medians and their ratio. Bar: logging slows the loop
by at most 10%. Full resolution costs about 14% here.

Run:  .venv/bin/python bench/rerun_overhead.py --json docs/results/bench_rerun.json
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from d2sr.atomic import write_result
from d2sr.jobs.session import run_sim
from d2sr.jobs.viewer import RerunLog
from d2sr.runtime.backends import Backend, open_backend
from d2sr.runtime.loop import Result
from d2sr.runtime.settings import RunSettings
from harness import check_output, output_args


def _once(net: Backend, seconds: float, sensors: int, rrd: Path | None) -> tuple[float, int]:
    frames = 0

    def count(_sensor: int, _res: Result) -> None:
        nonlocal frames
        frames += 1

    t = time.perf_counter()
    if rrd is None:
        run_sim(net, None, "damped", sensors, seconds, 6, 0, repair="all", on_result=count)
    else:
        with RerunLog(rrd, sensors) as log:

            def both(sensor: int, res: Result) -> None:
                count(sensor, res)
                log.write(sensor, res)

            run_sim(net, None, "damped", sensors, seconds, 6, 0, repair="all", on_result=both)
    return time.perf_counter() - t, frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--sensors", type=int, default=3)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    net = open_backend(RunSettings(model="unet8", backend="onnx"))
    plain, logged, frames, size = [], [], 0, 0
    with tempfile.TemporaryDirectory() as tmp:
        _once(net, 2.0, args.sensors, None)  # warm up the sessions
        for k in range(args.repeats):
            s, frames = _once(net, args.seconds, args.sensors, None)
            plain.append(s)
            rrd = Path(tmp) / f"run{k}.rrd"
            s, _ = _once(net, args.seconds, args.sensors, rrd)
            logged.append(s)
            size = rrd.stat().st_size
    result = {
        "what": f"d2sr run sim: {args.sensors} sensors x {args.seconds:g} s, every frame repaired, 640x480",
        "frames": frames,
        "repeats": args.repeats,
        "seconds_median": {
            "plain": round(statistics.median(plain), 3),
            "rerun": round(statistics.median(logged), 3),
        },
        "slowdown": round(statistics.median(logged) / statistics.median(plain) - 1, 4),
        "rrd_mb": round(size / 2**20, 1),
        "bar": {"slowdown_at_most": 0.10},
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
