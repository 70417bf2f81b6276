"""Benchmark: detector, recovery UNets and detect+repair at 640x480 on this machine's CPU (torch and
onnxruntime), plus ``d2sr recover --repair all`` timed from outside the process. Bars: detector >= 300 fps,
detect + UNet8 repair of every frame >= 30 fps.

Run:  .venv/bin/python bench/models.py --json docs/results/bench_models.json
"""

from __future__ import annotations

import argparse

from d2sr.atomic import write_result
from d2sr.eval.speed import bench_models
from harness import check_output, output_args


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--threads", type=int, default=2)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result = bench_models(repeats=args.repeats, threads=args.threads, progress=print)
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
