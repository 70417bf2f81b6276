"""Prototype (issue 43): a learned refinement of synthesized frames, the paper's proposal (Sec. VII) of
fusing the warped prior depth with the current colour frame. Trained on the simulator's moving robot with
its colour camera (``d2sr.sim.colour``), judged on the real hand-held D435, which it never sees.

The network mirrors the recovery UNet's do-no-harm shape: a mask head flags warped pixels that are wrong
(more than 5 cm off, or missing where the scene has depth) and a depth head corrects a push-pull fill of
the pixels it trusts; unflagged pixels come out as the warp made them.

Run:  python -m lab.refine_proto gen --rooms 24 --out /tmp/refine/data.npz
      python -m lab.refine_proto train --data /tmp/refine/data.npz --steps 1500 --out /tmp/refine/net.pt
      python -m lab.refine_proto eval --net /tmp/refine/net.pt --data-dir ../shared/data
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np

WRONG_M = 0.05
CROP, CROPS = 128, 4


def gen(rooms: int, out: Path, first: int = 3000, seconds: float = 20.0) -> None:
    from d2sr.jobs.session import rig_intrinsics
    from d2sr.sim.colour import grey
    from d2sr.sim.rooms import Renderer
    from d2sr.sim.world import make_rig
    from d2sr.synth import Filler

    xs, ys = [], []
    for seed in range(first, first + rooms):
        rng = np.random.default_rng(seed)
        n = int(rng.choice([6, 15]))
        rig = make_rig(seed, sensors=2, moving_robot=True, people=int(rng.integers(0, 3)))
        cam = Renderer(rig.room, rig.intr)
        f = Filler(rig_intrinsics(rig))
        for i in range(round(seconds * 30)):
            t = i / 30
            cam.move(rig.pose(1, t))
            r = cam.render(t)
            true = r.depth.astype(np.float32)
            true[(true < 0.25) | (true > 9)] = 0
            img = grey(cam, r, float(rng.uniform(1, 4)), rng)
            if i % 30 < n:
                f.real(true, img)
                continue
            s = f.synthesize(img)
            if (i - n) % 2:
                continue
            x = np.stack([s.depth, s.confidence, img.astype(np.float32) / 255]).astype(np.float16)
            wrong = np.argwhere((true > 0) & ((s.depth <= 0) | (np.abs(s.depth - true) > WRONG_M)))
            for c in range(CROPS):  # half the crops centred on a wrong pixel, half anywhere
                if c % 2 == 0 and len(wrong):
                    v, u = wrong[rng.integers(len(wrong))]
                else:
                    v, u = rng.integers(0, true.shape[0]), rng.integers(0, true.shape[1])
                v0 = int(np.clip(v - CROP // 2, 0, true.shape[0] - CROP))
                u0 = int(np.clip(u - CROP // 2, 0, true.shape[1] - CROP))
                xs.append(x[:, v0 : v0 + CROP, u0 : u0 + CROP])
                ys.append(true[v0 : v0 + CROP, u0 : u0 + CROP].astype(np.float16))
        print(seed, len(xs), flush=True)
    np.savez(out, x=np.stack(xs), y=np.stack(ys))


def net():
    import torch
    import torch.nn.functional as F
    from torch import nn

    from d2sr.models.unet import push_pull, space_to_depth

    def block(cin: int, cout: int) -> nn.Sequential:
        return nn.Sequential(
            nn.Conv2d(cin, cout, 3, padding=1),
            nn.ReLU(inplace=True),
            nn.Conv2d(cout, cout, 3, padding=1),
            nn.ReLU(inplace=True),
        )

    class Refine(nn.Module):
        def __init__(self, width: int = 12, s2d: int = 2) -> None:
            super().__init__()
            self.s2d = s2d
            cin = 4 * s2d * s2d
            widths = [width, width * 2, width * 4]
            self.down = nn.ModuleList()
            c = cin
            for w in widths:
                self.down.append(block(c, w))
                c = w
            self.up = nn.ModuleList(block(widths[k + 1] + widths[k], widths[k]) for k in range(2))
            self.head = nn.Sequential(
                nn.Conv2d(widths[0] + cin, 32, 1), nn.ReLU(inplace=True), nn.Conv2d(32, 2 * s2d * s2d, 1)
            )

        def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            w, conf, g = x[:, :1], x[:, 1:2], x[:, 2:3]
            feats = torch.cat([w / 4, (w > 0).to(w.dtype), conf, g], 1)
            h0 = space_to_depth(feats, self.s2d, 4)
            skips, h = [], h0
            for k, b in enumerate(self.down):
                if k:
                    h = F.max_pool2d(h, 2)
                h = b(h)
                skips.append(h)
            for k in (1, 0):
                h = F.interpolate(h, scale_factor=2.0, mode="nearest")
                h = self.up[k](torch.cat([h, skips[k]], 1))
            out = F.pixel_shuffle(self.head(torch.cat([h, h0], 1)), self.s2d)
            logit, corr = out[:, :1], out[:, 1:2]
            trust = (w > 0).to(w.dtype) * (1 - torch.sigmoid(logit.detach()))
            return logit, push_pull(w, trust) + corr

    return Refine()


def train(data: list[Path], steps: int, out: Path, batch: int = 16) -> None:
    import torch
    import torch.nn.functional as F

    torch.manual_seed(0)
    parts = [np.load(p) for p in data]
    x = np.concatenate([d["x"] for d in parts])
    y = np.concatenate([d["y"] for d in parts])
    print("frames", len(x))
    m = net()
    opt = torch.optim.Adam(m.parameters(), 1e-3)
    rng = np.random.default_rng(0)
    t0 = time.time()
    for step in range(steps):
        idx = rng.integers(0, len(x), batch)
        xb = torch.from_numpy(x[idx].astype(np.float32))
        yb = torch.from_numpy(y[idx, None].astype(np.float32))
        wb = xb[:, :1]
        has = yb > 0
        wrong = has & ((wb <= 0) | ((wb - yb).abs() > WRONG_M))
        logit, pred = m(xb)
        loss_mask = F.binary_cross_entropy_with_logits(logit, wrong.float())
        loss_depth = ((pred - yb).abs() * wrong).sum() / wrong.sum().clamp(min=1)
        loss = loss_mask + loss_depth
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 100 == 0:
            print(
                step,
                round(loss_mask.item(), 4),
                round(loss_depth.item(), 4),
                round(time.time() - t0),
                flush=True,
            )
    torch.save(m.state_dict(), out)


def refine(m, depth: np.ndarray, conf: np.ndarray, g: np.ndarray, logit_min: float = 0.0) -> np.ndarray:
    import torch

    x = torch.from_numpy(np.stack([depth, conf, g.astype(np.float32) / 255])[None].astype(np.float32))
    with torch.no_grad():
        logit, pred = m(x)
    fix = logit[0, 0].numpy() > logit_min
    return np.where(fix, np.maximum(pred[0, 0].numpy(), 0), depth).astype(np.float32)


def evaluate(path: Path, data: Path, logit_min: float) -> None:
    import torch

    from d2sr.synth import Filler
    from d2sr.synth.warp import guess_intrinsics

    m = net()
    m.load_state_dict(torch.load(path))
    m.eval()
    seq = data / "d435"
    files = sorted(seq.glob("depth*.png"))
    rgbs = sorted((seq / "rgb").glob("*.jpg"))
    D = [cv2.imread(str(f), -1).astype(np.float32) / 1000 for f in files]
    C = [cv2.imread(str(f), cv2.IMREAD_COLOR) for f in rgbs]
    for n in (15, 6):
        f = Filler(guess_intrinsics(640, 480))
        acc = {"warp": [0.0, 0, 0], "refined": [0.0, 0, 0]}
        worst = {"warp": 0.0, "refined": 0.0}  # the worst single frame's RMSE
        ms = []
        for i in range(len(D)):
            if i % 30 < n:
                f.real(D[i], C[i])
                continue
            s = f.synthesize(C[i])
            t0 = time.perf_counter()
            r = refine(m, s.depth, s.confidence, cv2.cvtColor(C[i], cv2.COLOR_BGR2GRAY), logit_min)
            ms.append(time.perf_counter() - t0)
            true = D[i]
            for k, p in (("warp", s.depth), ("refined", r)):
                ok = (true > 0) & (true < 8)
                both = ok & (p > 0) & (p < 8)
                acc[k][0] += float(((p - true)[both] ** 2).sum())
                acc[k][1] += int(both.sum())
                acc[k][2] += int(ok.sum())
                if both.any():
                    worst[k] = max(worst[k], float(np.sqrt(np.mean((p - true)[both] ** 2))))
        pooled = {k: (round(100 * np.sqrt(a / b), 2), round(b / c, 4)) for k, (a, b, c) in acc.items()}
        print(
            n,
            pooled,
            "worst frame cm",
            {k: round(100 * v, 1) for k, v in worst.items()},
            "ms",
            round(1000 * float(np.median(ms)), 1),
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("--rooms", type=int, default=24)
    g.add_argument("--first", type=int, default=3000)
    g.add_argument("--out", type=Path, required=True)
    t = sub.add_parser("train")
    t.add_argument("--data", type=Path, nargs="+", required=True)
    t.add_argument("--steps", type=int, default=1500)
    t.add_argument("--out", type=Path, required=True)
    e = sub.add_parser("eval")
    e.add_argument("--net", type=Path, required=True)
    e.add_argument("--data-dir", type=Path, default=Path("../shared/data"))
    e.add_argument("--logit-min", type=float, default=0.0)
    a = ap.parse_args()
    if a.cmd in ("gen", "train") and a.out.exists():
        ap.error(f"{a.out} exists: give a new --out (nothing is overwritten)")
    if a.cmd == "gen":
        gen(a.rooms, a.out, a.first)
    elif a.cmd == "train":
        train(a.data, a.steps, a.out)
    else:
        evaluate(a.net, a.data_dir, a.logit_min)


if __name__ == "__main__":
    main()
