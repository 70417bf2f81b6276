"""Probe (issue 68): depth carried into what the camera newly sees along the colour frame, at chosen colour
tolerances. The product's pass (``d2sr.synth.along``: after the warp and the background fill, each remaining
hole takes the colour-weighted mean of its filled 8-neighbours at 1/``--level`` of the side, weights
exp(-|Lab difference|^2 / 2 sigma^2), up to ``--iters`` steps) run with ``--sigma`` (confidence 0.25) and,
when given, a second pass ``--sigma2`` over what is left (0.1); ``--off``: no colour pass, the fill as it was
before. Measured on the hand-held D435 sequence as ``lab.fill_d435`` measures it (n = 15 and 6 of 30 kept,
RMSE and coverage against hold-last's), and with every second frame dropped (``--step 2``: the camera turns
twice as far between frames, as in the held-out Kinect v1 sequence whose coverage fell short). It sets the
module's ``STEPS``, ``LEVEL`` and ``REACH`` in this process only.

Run:  python -m lab.fill_colour_probe --data ../shared/data --step 2 --sigma 4 [--sigma2 7] [--off]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from d2sr.synth import FillSettings, along, fill_recording
from lab.fill_d435 import FAR_MM, stepped
from lab.fill_eval import PooledError


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--step", type=int, default=1, help="keep every step-th frame (2: a faster turn)")
    ap.add_argument("--sigma", type=float, default=4.0)
    ap.add_argument("--sigma2", type=float, default=0.0, help="a second pass over what is left (0: none)")
    ap.add_argument("--iters", type=int, default=along.REACH)
    ap.add_argument("--level", type=int, default=along.LEVEL, help="the propagation at 1/level of the side")
    ap.add_argument("--off", action="store_true", help="no colour pass: the fill before it, same frames")
    args = ap.parse_args()
    steps = [] if args.off else [(args.sigma, 0.25)] + ([(args.sigma2, 0.1)] if args.sigma2 else [])
    along.STEPS, along.REACH, along.LEVEL = tuple(steps), args.iters, args.level
    with tempfile.TemporaryDirectory() as tmp:
        seq = stepped(args.data / "d435", args.step, Path(tmp))
        files = sorted(seq.glob("depth*.png"))
        real = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float64) for f in files]
        for n in (15, 6):
            out = Path(tmp) / f"out{n}"
            t = time.perf_counter()
            fill_recording(seq, out, FillSettings(active_frames=n, colour=seq / "rgb"))
            seconds = time.perf_counter() - t
            ours, hold = PooledError(1000, FAR_MM), PooledError(1000, FAR_MM)
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
