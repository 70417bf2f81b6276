"""Probe (issue 68): depth carried into what the camera newly sees along the colour frame. After the warp of
the last real frame and the background fill (``d2sr.synth``), each remaining hole takes the colour-weighted
mean of its filled 8-neighbours at 1/``--level`` of the side (weights exp(-|Lab difference|^2 / 2 sigma^2)),
``--iters`` times, so depth spreads into regions of the colour it came from and stops at colour edges; filled
pixels get confidence 0.25. Not in ``src``: measured on the hand-held D435 sequence as ``lab.fill_d435``
measures it (n = 15 and 6 of 30 kept, RMSE and coverage against hold-last's), and on the same sequence with
every second frame dropped (``--step 2``: the camera turns twice as far between frames, as in the held-out
Kinect v1 sequence whose coverage fell short). Monkeypatches ``Filler.synthesize``; slow (Python loops).

Run:  python -m lab.fill_colour_probe --data ../shared/data --step 2 --sigma 4 --iters 60 --level 8 [--off]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from d2sr.synth import FillSettings, fill_recording
from d2sr.synth import fill as F
from lab.fill_eval import Pool

STEPS = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]


def colour_fill(depth: np.ndarray, colour: np.ndarray, sigma: float, iters: int, level: int) -> np.ndarray:
    """``depth`` (metres, 0 = hole) with its holes filled along ``colour`` (BGR or grey), at 1/``level`` of
    the side; nothing comes in from beyond the frame's edges."""
    hole = depth == 0
    if not hole.any():
        return depth
    h, w = depth.shape
    sh, sw = h // level, w // level
    if colour.ndim == 3:
        lab = cv2.cvtColor(colour, cv2.COLOR_BGR2LAB).astype(np.float32)
    else:
        lab = np.repeat((colour.astype(np.float32) * np.float32(100 / 255))[..., None], 3, 2)
    c = np.pad(cv2.resize(lab, (sw, sh), interpolation=cv2.INTER_AREA), ((1, 1), (1, 1), (0, 0)), mode="edge")
    valid = (~hole).astype(np.float32)
    dsum = cv2.resize(depth * valid, (sw, sh), interpolation=cv2.INTER_AREA)
    vsum = cv2.resize(valid, (sw, sh), interpolation=cv2.INTER_AREA)
    d = np.zeros((sh + 2, sw + 2), np.float32)  # a border of no depth
    core = d[1:-1, 1:-1]
    core[...] = np.where(vsum > 0.5, dsum / np.maximum(vsum, 1e-6), 0)
    inv = np.float32(-1 / (2 * sigma * sigma))
    centre = c[1:-1, 1:-1]
    weights = [
        np.exp(((centre - c[1 + dy : 1 + dy + sh, 1 + dx : 1 + dx + sw]) ** 2).sum(2) * inv)
        for dy, dx in STEPS
    ]
    for _ in range(iters):
        empty = core == 0
        num, den = np.zeros_like(core), np.zeros_like(core)
        for (dy, dx), wgt in zip(STEPS, weights, strict=True):
            near = d[1 + dy : 1 + dy + sh, 1 + dx : 1 + dx + sw]
            wn = wgt * (near > 0)
            num += wn * near
            den += wn
        new = empty & (den > 0.5)
        if not new.any():
            break
        core[new] = num[new] / den[new]
    up = cv2.resize(core, (w, h), interpolation=cv2.INTER_NEAREST)
    out = depth.copy()
    out[hole] = up[hole]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--step", type=int, default=1, help="keep every step-th frame (2: a faster turn)")
    ap.add_argument("--sigma", type=float, default=4.0)
    ap.add_argument("--iters", type=int, default=60)
    ap.add_argument("--level", type=int, default=8, help="the propagation at 1/level of the side")
    ap.add_argument("--off", action="store_true", help="the shipped fill alone, for the same frames")
    ap.add_argument("--sigma2", type=float, default=0.0, help="a second pass over what is left (0: none)")
    args = ap.parse_args()
    shipped = F.Filler.synthesize

    def synthesize(self: F.Filler, colour: np.ndarray | None = None, pose: object = None) -> F.Synthesized:
        s = shipped(self, colour, pose)  # type: ignore[arg-type]
        if args.off or colour is None:
            return s
        d = colour_fill(s.depth, colour, args.sigma, args.iters, args.level)
        conf = np.where((s.depth == 0) & (d > 0), np.float32(0.25), s.confidence)
        if args.sigma2:
            d2 = colour_fill(d, colour, args.sigma2, args.iters, args.level)
            conf = np.where((d == 0) & (d2 > 0), np.float32(0.1), conf)
            d = d2
        return F.Synthesized(d, conf, s.method, s.since_real)

    F.Filler.synthesize = synthesize  # type: ignore[method-assign]
    src = args.data / "d435"
    with tempfile.TemporaryDirectory() as tmp:
        seq = Path(tmp) / "seq"
        (seq / "rgb").mkdir(parents=True)
        for i, f in enumerate(sorted(src.glob("depth*.png"))[:: args.step]):
            os.symlink(f.resolve(), seq / f"depth{i:05d}.png")
            rgb = src / "rgb" / f.name.replace("depth", "rgb").replace(".png", ".jpg")
            os.symlink(rgb.resolve(), seq / "rgb" / f"rgb{i:05d}.jpg")
        files = sorted(seq.glob("depth*.png"))
        real = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float64) for f in files]
        for n in (15, 6):
            out = Path(tmp) / f"out{n}"
            t = time.perf_counter()
            fill_recording(seq, out, FillSettings(active_frames=n, colour=seq / "rgb"))
            seconds = time.perf_counter() - t
            ours, hold = Pool(1000, 8000), Pool(1000, 8000)
            for i, f in enumerate(files):
                if i % 30 < n:
                    continue
                ours.add(cv2.imread(str(out / f.name), cv2.IMREAD_UNCHANGED).astype(np.float64), real[i])
                hold.add(real[(i // 30) * 30 + n - 1], real[i])
            print(
                f"step {args.step} n {n}: RMSE vs hold-last {ours.rmse_cm() / hold.rmse_cm():.3f}, coverage vs "
                f"hold-last {ours.coverage() / hold.coverage():.3f}, {len(files) / seconds:.1f} frames/s",
                flush=True,
            )


if __name__ == "__main__":
    main()
