"""Prototype (issue 43, lab/notes/decisions.md 2026-11-27): colour motion by tracking the last real
frame's corners, against the chained ORB motion of ``d2sr.synth``, on the simulator's moving robot with
its colour camera. Prints RMSE (cm, pooled) of each method's warp, odometry's and hold-last's, the median
and 90th-percentile translation error (mm) and ms a frame.

Run:  python -m lab.klt_motion --seeds 100,101,102 --seconds 20
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np

from d2sr.jobs.session import odometry, rig_intrinsics
from d2sr.sim.colour import grey
from d2sr.sim.rooms import Renderer
from d2sr.sim.world import make_rig
from d2sr.synth import Filler
from d2sr.synth.warp import Pose


class Track:
    def __init__(self, k, corners=600):
        self.k = k
        self.corners = corners
        self.cam = np.array([[k.fx, 0, k.px], [0, k.fy, k.py], [0, 0, 1.0]])
        self.pts3 = None

    def real(self, grey, metres):
        c = cv2.goodFeaturesToTrack(grey, self.corners, 0.01, 7)
        self.prev = grey
        self.pts3 = None
        self.pose = Pose.identity()
        if c is None:
            return
        uv = c.reshape(-1, 2)
        ui, vi = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
        z = metres[np.clip(vi, 0, metres.shape[0] - 1), np.clip(ui, 0, metres.shape[1] - 1)]
        ok = z > 0
        k = self.k
        self.pts3 = np.stack([(uv[ok, 0] - k.px) * z[ok] / k.fx, (uv[ok, 1] - k.py) * z[ok] / k.fy, z[ok]], 1)
        self.uv = uv[ok].astype(np.float32)

    def step(self, grey):
        """(pose real->current, measured, still)"""
        if self.pts3 is None or len(self.uv) < 12:
            self.prev = grey
            return self.pose, False, False
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(self.prev, grey, self.uv, None, winSize=(21, 21), maxLevel=3)
        back, st2, _ = cv2.calcOpticalFlowPyrLK(grey, self.prev, nxt, None, winSize=(21, 21), maxLevel=3)
        good = (st.ravel() == 1) & (st2.ravel() == 1) & (np.linalg.norm(back - self.uv, axis=1) < 0.5)
        self.pts3, self.uv, self.prev = self.pts3[good], nxt[good], grey
        if len(self.uv) < 30:
            return self.pose, False, False
        rvec, _ = cv2.Rodrigues(self.pose.R)
        ok, rvec, tvec, inl = cv2.solvePnPRansac(
            self.pts3, self.uv.astype(np.float64), self.cam, None, rvec.copy(),
            self.pose.t.reshape(3, 1).copy(), useExtrinsicGuess=True, reprojectionError=3.0, iterationsCount=100,
        )  # fmt: skip
        if not ok or inl is None or len(inl) < 12:
            return self.pose, False, False
        R, _ = cv2.Rodrigues(rvec)
        pose = Pose(R, tvec.reshape(3))
        step = self.pose.inverse().then(pose)
        ang = np.degrees(np.arccos(np.clip((np.trace(step.R) - 1) / 2, -1, 1)))
        if np.linalg.norm(step.t) > 0.15 or ang > 10:
            return self.pose, False, False
        keep = inl.ravel()
        obj, img = self.pts3[keep], self.uv[keep].astype(np.float64)

        def proj(p):
            return np.stack(
                [self.k.fx * p[:, 0] / p[:, 2] + self.k.px, self.k.fy * p[:, 1] / p[:, 2] + self.k.py], 1
            )

        ssr_fit = ((proj(obj @ R.T + pose.t) - img) ** 2).sum()
        ssr_none = ((proj(obj) - img) ** 2).sum()
        n = len(obj)
        still = (2 * n - 6) * np.log(max(ssr_none, 1e-9) / max(ssr_fit, 1e-9)) <= 22.46
        self.pose = pose
        return pose, True, still


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    for n in (15, 6):
        se: dict = {"orb": [], "klt": [], "pose": [], "hold": []}
        terr: dict = {"orb": [], "klt": []}
        tt = {"orb": 0.0, "klt": 0.0}
        for seed in seeds:
            rig = make_rig(seed, sensors=2, moving_robot=True)
            cam = Renderer(rig.room, rig.intr)
            k = rig_intrinsics(rig)
            fo, fk, fp, tr = Filler(k), Filler(k), Filler(k), Track(k)
            rng = np.random.default_rng(seed)
            for i in range(round(args.seconds * 30)):
                t = i / 30
                cam.move(rig.pose(1, t))
                r = cam.render(t)
                true = r.depth.astype(np.float32)
                img = grey(cam, r, 2.0, rng)
                pose = odometry(rig, 1, t)
                if i % 30 < n:
                    fo.real(true, img)
                    fp.real(true, pose=pose)
                    fk.real(true, pose=Pose.identity())
                    tr.real(img, true)
                    last, src = true, pose
                    continue
                t0 = time.perf_counter()
                so = fo.synthesize(img)
                tt["orb"] += time.perf_counter() - t0
                t0 = time.perf_counter()
                mv, _, still = tr.step(img)
                mv = Pose.identity() if still else mv
                sk = fk.synthesize(pose=mv.inverse())
                tt["klt"] += time.perf_counter() - t0
                sp = fp.synthesize(pose=pose)
                truth = src.then(pose.inverse())
                terr["orb"].append(np.linalg.norm(fo._moved.t - truth.t))
                terr["klt"].append(np.linalg.norm(mv.t - truth.t))
                for m, d in (("orb", so.depth), ("klt", sk.depth), ("pose", sp.depth), ("hold", last)):
                    ok = (d > 0) & (true > 0)
                    se[m].append((((d - true)[ok] ** 2).sum(), ok.sum()))
        rmse = {
            m: round(float(np.sqrt(sum(a for a, _ in v) / sum(c for _, c in v))) * 100, 1)
            for m, v in se.items()
        }
        print(
            n, "rmse cm", rmse,
            "median t err mm", {m: round(float(np.median(v)) * 1000, 1) for m, v in terr.items()},
            "p90", {m: round(float(np.percentile(v, 90)) * 1000, 1) for m, v in terr.items()},
            "ms", {m: round(v / len(terr["orb"]) * 1000, 1) for m, v in tt.items()},
            flush=True,
        )  # fmt: skip


if __name__ == "__main__":
    main()
