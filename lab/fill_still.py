"""Benchmark (issue 43, "a still sensor: the synthesized frames are no worse than hold-last"). Two still
cameras, slots 0..5 of every 30 kept:

* the real still L515 sequences dev0 and dev1 (depth only, so synthesis holds): ``d2sr fill`` against the
  real frames it replaces, beside holding the last kept frame;
* a still camera with colour: one real D435 frame (depth and colour) held still for 60 frames, each colour
  frame with fresh sensor noise (Gaussian, 2 levels) and JPEG quality 92, as a camera that does not move
  delivers it. Hold-last is exact there; synthesis from colour may move it by what PnP reads into noise.

Reports RMSE (cm, pooled, valid under 8 m) and the worst frame's, for both methods.

Run:  python -m lab.fill_still --data ../shared/data --json docs/results/fill_still.json
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.synth import Filler, FillSettings, fill_recording
from lab.fill_eval import PooledError

ACTIVE = 6
FRAMES = 60


def l515(seq: Path) -> dict:
    """``d2sr fill`` (depth only) on a real still L515 sequence against hold-last."""
    files = sorted(seq.glob("*.png"))
    real = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float64) for f in files]
    ours, hold = PooledError(4000, 8 * 4000), PooledError(4000, 8 * 4000)
    with tempfile.TemporaryDirectory() as tmp:
        fill_recording(seq, Path(tmp) / "f", FillSettings(active_frames=ACTIVE, depth_scale=4000.0))
        for i, f in enumerate(files):
            if i % 30 < ACTIVE:
                continue
            got = cv2.imread(str(Path(tmp) / "f" / f.name), cv2.IMREAD_UNCHANGED).astype(np.float64)
            ours.add(got, real[i])
            hold.add(real[(i // 30) * 30 + ACTIVE - 1], real[i])
    return {"frames": len(files), "rmse_cm": ours.rmse_cm(), "hold_last_rmse_cm": hold.rmse_cm()}


def d435_still(data: Path, k: int, seed: int) -> dict:
    """One D435 frame held still with noisy colour: synthesis from colour against the truth (that frame)."""
    depth = sorted((data / "d435").glob("depth*.png"))[k]
    rgb = sorted((data / "d435" / "rgb").glob("*.jpg"))[k]
    d = cv2.imread(str(depth), cv2.IMREAD_UNCHANGED).astype(np.float32) / 1000
    d[d > 8] = 0
    c = cv2.imread(str(rgb), cv2.IMREAD_COLOR)
    rng = np.random.default_rng(seed)
    f, pool, worst = Filler(), PooledError(), 0.0
    for i in range(FRAMES):
        noisy = np.clip(c + rng.normal(0, 2.0, c.shape), 0, 255).astype(np.uint8)
        noisy = cv2.imdecode(cv2.imencode(".jpg", noisy, [cv2.IMWRITE_JPEG_QUALITY, 92])[1], cv2.IMREAD_COLOR)
        if i % 30 < ACTIVE:
            f.real(d, noisy)
            continue
        s = f.synthesize(noisy)
        pool.add(s.depth, d)
        one = PooledError()
        one.add(s.depth, d)
        worst = max(worst, one.rmse_cm())
    return {
        "frame": depth.name,
        "rmse_cm": pool.rmse_cm(),
        "worst_frame_rmse_cm": worst,
        "hold_last_rmse_cm": 0.0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result: dict = {"active_frames": ACTIVE}
    for view in ("dev0", "dev1"):
        result[f"l515_{view}"] = l515(args.data / "l515" / view)
        print(view, result[f"l515_{view}"], flush=True)
    result["d435_still"] = [d435_still(args.data, k, k) for k in (0, 60, 120)]
    print(result["d435_still"], flush=True)
    print(write_result(result, args.json, data=f"{args.data}: L515 dev0/dev1 (still), D435 frames 0/60/120"))


if __name__ == "__main__":
    main()
