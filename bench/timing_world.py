"""Benchmark: the timing world at warehouse scale (1,000 sensors for 600 s; bar: under 60 s on 2 cores).

Run:  .venv/bin/python bench/timing_world.py --json docs/results/bench_timing.json
Same as `d2sr bench`; kept here so every benchmark lives under bench/.
"""

from __future__ import annotations

import argparse

from rich.progress import Progress, TimeElapsedColumn

from d2sr.atomic import write_result
from d2sr.eval.speed import bench_timing
from harness import check_output, output_args


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sensors", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--repeats", type=int, default=3)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    with Progress(*Progress.get_default_columns(), TimeElapsedColumn()) as bar:
        task = bar.add_task("warehouse", total=1.0)
        result = bench_timing(
            args.sensors, args.seconds, args.repeats, progress=lambda f: bar.update(task, completed=f)
        )
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
