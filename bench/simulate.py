"""Benchmark: d2sr simulate writes 1,000 frames at 640x480 (bar: under 60 s on 2 cores).

Run:  .venv/bin/python bench/simulate.py --json docs/results/bench_simulate.json
"""

from __future__ import annotations

import argparse

from d2sr.atomic import write_result
from d2sr.eval.speed import bench_simulate
from harness import check_output, output_args


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result = bench_simulate(args.frames, args.repeats, args.workers)
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
