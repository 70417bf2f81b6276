"""Benchmark (issue 44): the two figures that decide whether a robot can afford d2sr, in one run.

* Typical case: CPU time a clean 640x480 L515 frame costs through ``d2sr.Pipeline`` in process, as shipped
  (every frame judged, against the sensor's scene too, and flagged ones repaired) and without the repair;
  each L515 view of the outside set (dev0 after the person has left, dev1), 60 frames in order. Bar: at
  most 5 ms. Also with ``scene=False`` (the detector alone), the default before 2026-11-27; and steady, a
  sensor that has run a while: each whole L515 sequence, timed after its first 60 frames (the scene's
  start-up, and dev0's walking person).
* Worst case: ``d2sr recover --repair all`` from outside the process on 60 real L515 frames, every one corrupted
  by interference the project's generator does not make (``bench.outside``'s ``worst_case``), against the floor any
  whole-process tool pays: the same PNGs read and written by OpenCV alone. Bar: at most 1.5x the floor.

Run:  python -m lab.speed --data ../shared/data --json docs/results/bench_speed.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.harness import check_output, output_args
from bench.outside.sets import OUTSIDE_CAMERAS, outside_set, used_models, worst_case

from d2sr.atomic import write_result
from d2sr.eval.speed import bench_typical, bench_worst
from d2sr.frames import open_frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--repeats", type=int, default=3, help="typical case: passes over each view (median)")
    ap.add_argument("--runs", type=int, default=5, help="worst case: runs of each command (median)")
    ap.add_argument("--model", default=None, help="recover's and the Pipeline's --model (default: theirs)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    clean = outside_set(args.data)
    typical, alone, steady = {}, {}, {}
    model = {"model": args.model} if args.model else {}
    for view in ("dev0", "dev1"):
        frames = [f for f, cam in zip(clean, OUTSIDE_CAMERAS, strict=True) if cam == view]
        typical[view] = bench_typical(frames, 4000.0, args.repeats, **model)
        alone[view] = bench_typical(frames, 4000.0, args.repeats, scene=False, **model)
        whole = [f.depth for f in open_frames(args.data / "l515" / view)]
        steady[view] = bench_typical(whole, 4000.0, args.repeats, warmup=0, settle=60, **model)
    worst = bench_worst([f for _, f in worst_case(args.data)], 4000.0, args.runs, args.model)
    result = {
        "benchmark": "issue 44: typical case (CPU per clean frame, in process) and worst case (from outside) "
        "against the PNG floor",
        "typical": typical,
        "typical_without_scene": alone,
        "typical_steady": steady,
        "worst": worst,
    }
    data = f"{args.data}/l515 (real L515 frames, dev0 and dev1)"
    print(write_result(result, args.json, models=used_models(args.model), data=data))


if __name__ == "__main__":
    main()
