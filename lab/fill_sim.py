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

Run:  python -m lab.fill_sim --json docs/results/fill_sim.json --plot docs/results/fill_sim.png
"""

from __future__ import annotations

import argparse

import numpy as np
from bench.harness import check_output, output_args

from d2sr.eval.speed import write_result
from d2sr.provenance import command_line
from d2sr.runtime.session import odometry, rig_intrinsics
from d2sr.sim.colour import grey
from d2sr.sim.rooms import Renderer
from d2sr.sim.world import make_rig
from d2sr.synth import Filler
from lab.fill_eval import Pool, plot_curves


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--rooms", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=0, help="rooms are seeds first..first+rooms-1")
    output_args(ap, plot="RMSE by frames since the last real one, PNG")
    args = ap.parse_args()
    check_output(ap, args)
    result: dict = {
        "data": f"{args.rooms} generated rooms (seeds {args.first_seed}.."
        f"{args.first_seed + args.rooms - 1}), the moving robot, {args.seconds:g} s each",
        "runs": [],
    }
    for n in (15, 6):
        pools = {m: Pool() for m in ("hold", "warp-pose", "warp-colour")}
        gaps: dict[str, dict[int, Pool]] = {m: {} for m in pools}
        common = {m: Pool() for m in pools}
        for seed in range(args.first_seed, args.first_seed + args.rooms):
            rig = make_rig(seed, sensors=2, moving_robot=True)
            cam = Renderer(rig.room, rig.intr)
            warp, colour, last = Filler(rig_intrinsics(rig)), Filler(rig_intrinsics(rig)), None
            rng = np.random.default_rng(seed)
            for i in range(round(args.seconds * 30)):
                t = i / 30
                cam.move(rig.pose(1, t))
                render = cam.render(t)
                true = render.depth.astype(np.float32)
                true[~np.isfinite(true)] = 0
                image = grey(cam, render, 2.0, rng)
                pose = odometry(rig, 1, t)  # camera to world
                if i % 30 < n:
                    warp.real(true, pose=pose)
                    colour.real(true, image)
                    last = true
                    continue
                gap = i % 30 - n + 1
                made = (
                    ("hold", last),
                    ("warp-pose", warp.synthesize(pose=pose).depth),
                    ("warp-colour", colour.synthesize(image).depth),
                )
                both = (true > 0) & np.logical_and.reduce([pred > 0 for _, pred in made])
                for method, pred in made:
                    common[method].add(pred, np.where(both, true, 0))
                    pools[method].add(pred, true)
                    gaps[method].setdefault(gap, Pool()).add(pred, true)
        result["runs"].append({
            "active_frames": n,
            **{f"{m}_rmse_cm": p.rmse_cm() for m, p in pools.items()},
            **{f"{m}_coverage": p.coverage() for m, p in pools.items()},
            **{f"{m}_common_rmse_cm": p.rmse_cm() for m, p in common.items()},
            "rmse_cm_by_frames_since_real": {
                m: {g: p.rmse_cm() for g, p in sorted(d.items())} for m, d in gaps.items()
            },
        })  # fmt: skip
        print({k: v for k, v in result["runs"][-1].items() if "by_frames" not in k}, flush=True)
    print(write_result(result, args.json))
    if args.plot is not None:
        curves = [
            (f"{m}, {run['active_frames']} of 30 kept", {"hold": "--", "warp-pose": "-"}.get(m, ":"), curve)
            for run in result["runs"]
            for m, curve in run["rmse_cm_by_frames_since_real"].items()
        ]
        title = "Synthesized frames on the simulator's moving robot (ground truth)"
        plot_curves(curves, title, command_line(), args.plot)


if __name__ == "__main__":
    main()
