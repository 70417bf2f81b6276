"""Benchmark: frame synthesis on the simulator's moving robot, where every skipped slot has ground truth (the
paper's Fig. 11 for our methods). The robot drives its loop through a generated room; slots 0..n-1 of every
30 are real (the rendered depth), the others are synthesized and compared with what the robot's camera
would have measured then. Methods: hold-last, and the warp by odometry (the trajectory's poses, as a
robot's odometry would give them), and the warp by the colour stream alone (``d2sr.sim.colour``: the
colour camera's grey image with 2 levels of sensor noise, the motion found by PnP as on a real camera).

RMSE pooled over pixels with depth in both the synthesized and the true frame; coverage = share of the true
frame's pixels given a value; ``common``: RMSE over the pixels every method gives a value, so that no method
is judged on pixels another leaves out (the robot's loop can pass through furniture, and there a warp by
odometry puts every point behind the camera while a method that cannot measure the motion holds).

The measure is the library's (``d2sr.eval.fill.moving_robot_fill``, also in ``d2sr eval paper``).

Run:  python -m lab.fill_sim --json docs/results/fill_sim.json --plot docs/results/fill_sim.png
"""

from __future__ import annotations

import argparse

from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.eval.fill import fig11, moving_robot_fill
from d2sr.eval.plots import save
from d2sr.provenance import command_line


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--rooms", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=0, help="rooms are seeds first..first+rooms-1")
    output_args(ap, plot="RMSE and coverage by frames since the last real one, PNG")
    args = ap.parse_args()
    check_output(ap, args)
    result = moving_robot_fill(args.rooms, args.seconds, args.first_seed)
    for run in result["runs"]:
        print({k: v for k, v in run.items() if "by_frames" not in k}, flush=True)
    print(write_result(result, args.json))
    if args.plot is not None:
        fig = fig11(result)
        fig.text(0.01, 0.0, command_line(), fontsize=6)
        save(fig, args.plot)


if __name__ == "__main__":
    main()
