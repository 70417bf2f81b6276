"""Benchmark: ``d2sr fill`` on the real hand-held D435 RGB-D sequence (``../shared/data/d435``, depth aligned
to colour), keeping slots 0..n-1 of every 30, against holding the last kept frame.

For each n: the RMSE of the synthesized frames against the real frames they replace, over pixels where
both have valid depth under 8 m (pooled over frames), and the coverage: the share of the real frames'
valid pixels the synthesized frames give a value; the same for hold-last; the ratios the issue's bar
reads (RMSE at most 50% of hold-last's, coverage at least 90% of hold-last's); kept frames bit-identical;
the RMSE by frames since the last real one (the paper's Fig. 11); frames a second; and per band of the
written confidence (1: the sensor's or warped; 0.5-1; 0.25-0.5; below 0.25) the share of the real frames'
valid pixels given a value in that band and its RMSE, so that a consumer's threshold can be read off;
and both RMSEs again over the pixels both methods give a value (``common_pixels``): each pooled RMSE above
is over its own pixels.
``--step 2`` keeps every second frame of the sequence (the camera turns twice as far between frames, as in
a faster hand-held sequence).

Run:  python -m lab.fill_d435 --data ../shared/data [--step 2] --json docs/results/fill_d435.json
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.provenance import command_line
from d2sr.synth import FillSettings, fill_recording
from lab.fill_eval import PooledError, plot_curves

FAR_MM = 8000
#: Bands of the written confidence (uint8, 255 = 1): (name, lowest, highest).
BANDS = (("1", 255, 255), ("0.5-1", 128, 254), ("0.25-0.5", 64, 127), ("below 0.25", 1, 63))


def stepped(src: Path, step: int, tmp: Path) -> Path:
    """``src`` (depth*.png and rgb/) with every ``step``-th frame kept, as links in ``tmp``."""
    if step == 1:
        return src
    seq = tmp / "seq"
    (seq / "rgb").mkdir(parents=True)
    for i, f in enumerate(sorted(src.glob("depth*.png"))[::step]):
        os.symlink(f.resolve(), seq / f"depth{i:05d}.png")
        rgb = src / "rgb" / f.name.replace("depth", "rgb").replace(".png", ".jpg")
        os.symlink(rgb.resolve(), seq / "rgb" / f"rgb{i:05d}.jpg")
    return seq


def read(p: Path) -> np.ndarray:
    return cv2.imread(str(p), cv2.IMREAD_UNCHANGED).astype(np.float64)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--step", type=int, default=1, help="keep every step-th frame (2: a faster turn)")
    output_args(ap, plot="RMSE by frames since the last real one (the paper's Fig. 11), PNG")
    args = ap.parse_args()
    check_output(ap, args)
    links = tempfile.TemporaryDirectory()
    seq = stepped(args.data / "d435", args.step, Path(links.name))
    files = sorted(seq.glob("depth*.png"))
    real = [read(f) for f in files]
    result: dict = {
        "data": f"{args.data / 'd435'} ({len(files)} frames, every {args.step}, hand-held D435, depth aligned "
        "to colour; development sequence)",
        "runs": [],
    }
    for n in (15, 6):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "filled"
            t = time.perf_counter()
            summary = fill_recording(seq, out, FillSettings(active_frames=n, colour=seq / "rgb"))
            seconds = time.perf_counter() - t
            ours, hold = PooledError(1000, FAR_MM), PooledError(1000, FAR_MM)
            # the same, over the pixels both give a depth for (each method's pooled RMSE is over its own)
            ours_common, hold_common = PooledError(1000, FAR_MM), PooledError(1000, FAR_MM)
            by_gap: dict[int, PooledError] = {}
            hold_gap: dict[int, PooledError] = {}
            bands = {name: PooledError(1000, FAR_MM) for name, _, _ in BANDS}
            identical = True
            for i, f in enumerate(files):
                got = read(out / f.name)
                if i % 30 < n:
                    identical &= bool(np.array_equal(got, real[i]))
                    continue
                held = real[(i // 30) * 30 + n - 1]
                conf = read(out / "confidence" / f.name)
                for name, lo, hi in BANDS:
                    bands[name].add(np.where((conf >= lo) & (conf <= hi), got, 0), real[i])
                ours.add(got, real[i])
                hold.add(held, real[i])
                both = (got > 0) & (got < FAR_MM) & (held > 0) & (held < FAR_MM)
                ours_common.add(np.where(both, got, 0), real[i])
                hold_common.add(np.where(both, held, 0), real[i])
                by_gap.setdefault(i % 30 - n + 1, PooledError(1000, FAR_MM)).add(got, real[i])
                hold_gap.setdefault(i % 30 - n + 1, PooledError(1000, FAR_MM)).add(held, real[i])
        result["runs"].append({
            "active_frames": n,
            "synthesized": summary.synthesized,
            "method": summary.method,
            "intrinsics": summary.intrinsics,
            "kept_identical": identical,
            "rmse_cm": ours.rmse_cm(),
            "hold_last_rmse_cm": hold.rmse_cm(),
            "rmse_vs_hold_last": round(ours.rmse_cm() / hold.rmse_cm(), 3),
            "common_pixels": {  # both methods judged on the same pixels
                "rmse_cm": ours_common.rmse_cm(),
                "hold_last_rmse_cm": hold_common.rmse_cm(),
                "rmse_vs_hold_last": round(ours_common.rmse_cm() / hold_common.rmse_cm(), 3),
            },
            "coverage": ours.coverage(),
            "hold_last_coverage": hold.coverage(),
            "coverage_vs_hold_last": round(ours.coverage() / hold.coverage(), 3),
            "by_confidence": {
                name: {"coverage": p.coverage(), "rmse_cm": p.rmse_cm(),
                       "rmse_vs_hold_last": round(p.rmse_cm() / hold.rmse_cm(), 3)}
                for name, p in bands.items()
            },
            "rmse_cm_by_frames_since_real": {k: p.rmse_cm() for k, p in sorted(by_gap.items())},
            "hold_last_rmse_cm_by_frames_since_real": {k: p.rmse_cm() for k, p in sorted(hold_gap.items())},
            "frames_per_second": round(len(files) / seconds, 1),
        })  # fmt: skip
        print(result["runs"][-1], flush=True)
    links.cleanup()
    print(write_result(result, args.json))
    if args.plot is not None:
        curves = []
        for run in result["runs"]:
            n = run["active_frames"]
            curves.append((f"d2sr fill, {n} of 30 kept", "-", run["rmse_cm_by_frames_since_real"]))
            curves.append((f"hold-last, {n} of 30 kept", "--", run["hold_last_rmse_cm_by_frames_since_real"]))
        title = "Synthesized frames against the real ones, hand-held D435"
        plot_curves(curves, title, command_line(), args.plot)


if __name__ == "__main__":
    main()
