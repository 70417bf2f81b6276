"""Synthesized frames measured where every skipped slot has ground truth: the simulator's moving robot (the
paper's Fig. 11, for d2sr's methods), with the coverage beside the RMSE.

The robot drives its loop through a generated room; slots 0..n-1 of every 30 are real (the rendered depth),
the others are synthesized and compared with what the robot's camera would have measured then. Methods:
hold-last, the warp by odometry (the trajectory's poses, as a robot's odometry gives them) and the warp by
the colour stream alone (the colour camera's grey image with sensor noise, the motion found by PnP).
RMSE is pooled over pixels with depth in both frames; coverage is the share of the true frame's pixels
given a value: a method that leaves a pixel empty is not judged on it, so the two are read together.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

__all__ = ["METHODS", "PooledError", "fig11", "moving_robot_fill"]

METHODS = ("hold", "warp-pose", "warp-colour")


class PooledError:
    """Pooled squared error over pixels with depth in both frames (``units`` per metre; values at or beyond
    ``far`` units count as no depth), and the share of the true frame's pixels the prediction covers."""

    def __init__(self, units: float = 1.0, far: float = np.inf) -> None:
        self.units, self.far = units, far
        self.se = self.both = self.true = 0.0

    def add(self, pred: np.ndarray, true: np.ndarray) -> None:
        ok = (true > 0) & (true < self.far)
        both = ok & (pred > 0) & (pred < self.far)
        self.se += float((((pred.astype(np.float64) - true) / self.units)[both] ** 2).sum())
        self.both += float(both.sum())
        self.true += float(ok.sum())

    def rmse_cm(self) -> float:
        return round(100 * float(np.sqrt(self.se / max(self.both, 1))), 2)

    def coverage(self) -> float:
        return round(self.both / max(self.true, 1), 4)


def moving_robot_fill(
    rooms: int = 3, seconds: float = 20.0, first_seed: int = 0, kept: tuple[int, ...] = (15, 6)
) -> dict[str, Any]:
    """Each method's RMSE and coverage on the moving robot, pooled and by frames since the last real one,
    for each number of real frames ``kept`` of 30; rooms are seeds ``first_seed..first_seed+rooms-1``."""
    from d2sr.jobs.session import odometry, rig_intrinsics
    from d2sr.sim.colour import grey
    from d2sr.sim.rooms import Renderer
    from d2sr.sim.world import make_rig
    from d2sr.synth import Filler

    result: dict[str, Any] = {
        "data": f"{rooms} generated rooms (seeds {first_seed}..{first_seed + rooms - 1}), the moving robot, "
        f"{seconds:g} s each",
        "runs": [],
    }
    pools = {n: {m: PooledError() for m in METHODS} for n in kept}
    gaps: dict[int, dict[str, dict[int, PooledError]]] = {n: {m: {} for m in METHODS} for n in kept}
    common = {n: {m: PooledError() for m in METHODS} for n in kept}
    for seed in range(first_seed, first_seed + rooms):
        rig = make_rig(seed, sensors=2, moving_robot=True)
        cam = Renderer(rig.room, rig.intr)
        # one pair of fillers (odometry, colour) and one last real frame per number of frames kept
        fillers = {n: (Filler(rig_intrinsics(rig)), Filler(rig_intrinsics(rig))) for n in kept}
        last: dict[int, np.ndarray] = {}
        rng = np.random.default_rng(seed)
        for i in range(round(seconds * 30)):
            t = i / 30
            cam.move(rig.pose(1, t))
            render = cam.render(t)
            true = np.where(np.isfinite(render.depth), render.depth, 0).astype(np.float32)
            image = grey(cam, render, 2.0, rng)
            pose = odometry(rig, 1, t)  # camera to world
            for n in kept:
                warp, colour = fillers[n]
                if i % 30 < n:
                    warp.real(true, pose=pose)
                    colour.real(true, image)
                    last[n] = true
                    continue
                gap = i % 30 - n + 1
                made = (
                    ("hold", last[n]),
                    ("warp-pose", warp.synthesize(pose=pose).depth),
                    ("warp-colour", colour.synthesize(image).depth),
                )
                both = (true > 0) & np.logical_and.reduce([pred > 0 for _, pred in made])
                for method, pred in made:
                    common[n][method].add(pred, np.where(both, true, 0))
                    pools[n][method].add(pred, true)
                    gaps[n][method].setdefault(gap, PooledError()).add(pred, true)
    for n in kept:
        result["runs"].append({
            "active_frames": n,
            **{f"{m}_rmse_cm": p.rmse_cm() for m, p in pools[n].items()},
            **{f"{m}_coverage": p.coverage() for m, p in pools[n].items()},
            **{f"{m}_common_rmse_cm": p.rmse_cm() for m, p in common[n].items()},
            "rmse_cm_by_frames_since_real": {
                m: {g: p.rmse_cm() for g, p in sorted(d.items())} for m, d in gaps[n].items()
            },
            "coverage_by_frames_since_real": {
                m: {g: p.coverage() for g, p in sorted(d.items())} for m, d in gaps[n].items()
            },
        })  # fmt: skip
    return result


def fig11(
    result: dict[str, Any], title: str = "Synthesized frames on the simulator's moving robot"
) -> Figure:
    """RMSE (left) and coverage (right) by frames since the last real one: one line per method and number
    of real frames kept."""
    from d2sr.eval.plots import plt  # Agg, set there

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6))
    colours = dict(zip(METHODS, ("tab:grey", "tab:blue", "tab:orange"), strict=True))
    styles = ("-", "--", ":")
    for run, style in zip(result["runs"], styles, strict=False):
        for ax, key in ((left, "rmse_cm_by_frames_since_real"), (right, "coverage_by_frames_since_real")):
            for m, curve in run.get(key, {}).items():
                gaps = sorted(curve, key=int)
                ax.plot(
                    [int(g) for g in gaps],
                    [curve[g] for g in gaps],
                    style,
                    color=colours.get(m),
                    marker="o",
                    ms=2,
                    label=f"{m}, {run['active_frames']} of 30 real",
                )
    left.set(xlabel="frames since the last real frame", ylabel="RMSE (cm)", ylim=(0, None))
    right.set(xlabel="frames since the last real frame", ylabel="coverage of the true frame", ylim=(0, 1.05))
    left.legend(fontsize=7)
    fig.suptitle(f"{title} (paper Fig. 11)", fontsize=10)
    fig.tight_layout()
    return fig
