"""Benchmark: controllers against the paper's Algorithm 1 while robots drive past fixed sensors (issue 68).

The worlds of ``d2sr.sim.passing``: a robot passing a ring of fixed sensors (each overlapping its two
ring neighbours; the robot two neighbours at a time, moving on every 8 periods), a robot passing a row and
back, two robots crossing along a row. Every sensor's frames count. Each cell (world, N, frames a second,
one of ``d2sr desync grid``'s 12 joint assumption settings) runs ``--rooms`` rooms of ``--seconds``, with
paired seeds across controllers: whole-run and steady (second half) interfered shares, and the default
minus Algorithm 1 in points with its standard error over rooms.

Run:  python -m lab.passing_grid --json docs/results/desync/passing_grid.json
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.desync import DEFAULT_CONTROLLER
from d2sr.eval.assumptions import settings
from d2sr.sim.passing import WORLDS, passing_rooms
from d2sr.sim.timing import TimingSettings, simulate


def cell(job: tuple[str, int, int, int, str, int, float]) -> dict[str, Any]:
    """One (world, N, fps, setting, controller): per-room whole and steady interfered shares."""
    world, n, fps, k, controller, rooms, seconds = job
    seed = 1000 + k
    graph = passing_rooms(world, n, seconds, rooms, seed)
    cfg = TimingSettings.make(active_frames=fps, **settings(12)[k])
    run = simulate(graph, controller, cfg, seconds, seed=seed)
    room = np.arange(graph.n) // n
    half = run.periods // 2

    def share(start: int) -> np.ndarray:
        cap = np.bincount(room, run.captured[:, start:].sum(1), rooms)
        bad = np.bincount(room, run.interfered[:, start:].sum(1), rooms)
        return np.divide(bad, cap, out=np.zeros(rooms), where=cap > 0)

    return {"world": world, "sensors": n, "fps": fps, "setting": k, "controller": controller,
            "whole": share(0).tolist(), "steady": share(half).tolist()}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rooms", type=int, default=40, help="rooms per cell")
    ap.add_argument("--seconds", type=float, default=60.0, help="each room's run")
    ap.add_argument("--controllers", default=f"{DEFAULT_CONTROLLER},d2sr", help="first one: the one judged")
    ap.add_argument("--fps", default="4,6,10", help="frames a second, comma separated")
    ap.add_argument(
        "--sensors", default="4,5,6", help="sensors a room, robots included (3 or fewer: nothing to pass)"
    )
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    controllers = args.controllers.split(",")
    jobs = [
        (w, n, f, k, c, args.rooms, args.seconds)
        for w in WORLDS
        for n in (int(x) for x in args.sensors.split(","))
        for f in (int(x) for x in args.fps.split(","))
        for k in range(12)
        for c in controllers
    ]
    with ProcessPoolExecutor(args.jobs) as pool:
        done = list(pool.map(cell, jobs, chunksize=2))
    by = {(d["world"], d["sensors"], d["fps"], d["setting"], d["controller"]): d for d in done}
    judged, ref = controllers[0], "d2sr"
    cells = []
    for (w, n, f, k, c), d in sorted(by.items()):
        if c != judged:
            continue
        r = by[(w, n, f, k, ref)]
        diff = 100 * (np.array(d["whole"]) - np.array(r["whole"]))
        cells.append({
            "world": w, "sensors": n, "fps": f, "setting": k,
            judged: round(float(np.mean(d["whole"])), 4), ref: round(float(np.mean(r["whole"])), 4),
            "diff_points": round(float(diff.mean()), 2),
            "diff_se_points": round(float(diff.std(ddof=1) / np.sqrt(diff.size)), 2),
            "steady": round(float(np.mean(d["steady"])), 4),
            "steady_" + ref: round(float(np.mean(r["steady"])), 4),
            "fits": n * (f + int(settings(12)[k]["setup"])) <= 25,
        })  # fmt: skip
    losing = [c for c in cells if c["diff_points"] > 0.3]
    fits = [c for c in cells if c["fits"]]
    result = {
        "judged": judged,
        "reference": ref,
        "settings": settings(12),
        "cells": len(cells),
        "cells_losing_over_0.3": len(losing),
        "losing": losing,
        "mean_diff_points": round(float(np.mean([c["diff_points"] for c in cells])), 3),
        "worst_steady_where_windows_fit": max(fits, key=lambda c: c["steady"]) if fits else None,
        "by_world": {
            w: {
                "mean_whole": round(float(np.mean([c[judged] for c in cells if c["world"] == w])), 4),
                "mean_whole_" + ref: round(float(np.mean([c[ref] for c in cells if c["world"] == w])), 4),
                "mean_steady": round(float(np.mean([c["steady"] for c in cells if c["world"] == w])), 4),
                "mean_steady_" + ref: round(
                    float(np.mean([c["steady_" + ref] for c in cells if c["world"] == w])), 4
                ),
            }
            for w in WORLDS
        },
        "all": cells,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
