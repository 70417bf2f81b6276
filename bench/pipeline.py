"""Benchmark: the runtime loop (detect, buffer, controller, repair) at 640x480 and 320x240 with 0%, 50% and
100% of frames interfered, peak memory, and ``d2sr run --repair all`` from outside the process. Bars: worst
case (every frame repaired, UNet8) >= 30 fps at 640x480 from outside; controller + buffering < 1% of a frame.

Run:  .venv/bin/python bench/pipeline.py --json docs/results/bench_pipeline.json
"""

from __future__ import annotations

import argparse

from d2sr.atomic import write_result
from d2sr.eval.speed import bench_pipeline
from harness import check_output, output_args


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    print(write_result(bench_pipeline(repeats=args.repeats, threads=args.threads, progress=print), args.json))


if __name__ == "__main__":
    main()
