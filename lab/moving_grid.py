"""Benchmark: the default controller against the paper's Algorithm 1 on the moving robot, across the
assumptions of ``d2sr desync grid`` (its 12 joint settings), where a held-out timing world built outside the
project found the default losing (N = 5, 6 frames a second). Only the robot's frames count; each cell runs
100 rooms of 60 s, paired seeds across the two controllers.

Run:  python -m lab.moving_grid --json docs/results/desync/moving_grid.json
"""

from __future__ import annotations

import argparse

import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.eval.assumptions import settings
from d2sr.eval.desync import Cell, run_cell


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rooms", type=int, default=100, help="rooms per cell")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    cells = []
    for sensors in (3, 5):
        for fps in (6, 10, 15):
            for k, s in enumerate(settings(12)):
                r = {
                    c: run_cell(Cell("moving", fps, sensors, c, replicas=args.rooms, seed=0), **s)
                    for c in (DEFAULT_CONTROLLER, "d2sr")
                }
                ours, ref = r[DEFAULT_CONTROLLER], r["d2sr"]
                diff = 100 * (np.array(ours.per_replica) - np.array(ref.per_replica))
                cells.append({
                    "sensors": sensors, "fps": fps, "setting": k,
                    DEFAULT_CONTROLLER: round(ours.whole, 4), "d2sr": round(ref.whole, 4),
                    "diff_points": round(100 * (ours.whole - ref.whole), 2),
                    "diff_se_points": round(float(diff.std(ddof=1) / np.sqrt(diff.size)), 2),
                    "steady": round(ours.steady, 4),
                })  # fmt: skip
                print(cells[-1], flush=True)
    losing = [c for c in cells if c["diff_points"] > 0.3]
    result = {
        "default": DEFAULT_CONTROLLER,
        "settings": settings(12),
        "cells_losing_over_0.3": len(losing),
        "losing": losing,
        "mean_diff_points": round(float(np.mean([c["diff_points"] for c in cells])), 3),
        "cells": cells,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
