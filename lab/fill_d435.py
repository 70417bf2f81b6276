"""Benchmark: ``d2sr fill`` on the real hand-held D435 RGB-D sequence (``../shared/data/d435``, depth aligned
to colour), keeping slots 0..n-1 of every 30, against holding the last kept frame.

For each n: the RMSE of the synthesized frames against the real frames they replace, over pixels where
both have valid depth under 8 m (pooled over frames), and the coverage: the share of the real frames'
valid pixels the synthesized frames give a value; the same for hold-last; the ratios the issue's bar
reads (RMSE at most 50% of hold-last's, coverage at least 90% of hold-last's); kept frames bit-identical;
the RMSE by frames since the last real one (the paper's Fig. 11); frames a second.

Run:  python -m lab.fill_d435 --data ../shared/data --json docs/results/fill_d435.json
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args

from d2sr.eval.speed import write_result
from d2sr.provenance import command_line
from d2sr.synth import FillSettings, fill_recording
from lab.fill_eval import Pool, plot_curves

FAR_MM = 8000


def read(p: Path) -> np.ndarray:
    return cv2.imread(str(p), cv2.IMREAD_UNCHANGED).astype(np.float64)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap, plot="RMSE by frames since the last real one (the paper's Fig. 11), PNG")
    args = ap.parse_args()
    check_output(ap, args)
    seq = args.data / "d435"
    files = sorted(seq.glob("depth*.png"))
    real = [read(f) for f in files]
    result: dict = {
        "data": f"{seq} ({len(files)} frames, hand-held D435, depth aligned to colour; development sequence)",
        "runs": [],
    }
    for n in (15, 6):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "filled"
            t = time.perf_counter()
            summary = fill_recording(seq, out, FillSettings(active_frames=n, colour=seq / "rgb"))
            seconds = time.perf_counter() - t
            ours, hold = Pool(1000, FAR_MM), Pool(1000, FAR_MM)
            by_gap: dict[int, Pool] = {}
            hold_gap: dict[int, Pool] = {}
            identical = True
            for i, f in enumerate(files):
                got = read(out / f.name)
                if i % 30 < n:
                    identical &= bool(np.array_equal(got, real[i]))
                    continue
                held = real[(i // 30) * 30 + n - 1]
                ours.add(got, real[i])
                hold.add(held, real[i])
                by_gap.setdefault(i % 30 - n + 1, Pool(1000, FAR_MM)).add(got, real[i])
                hold_gap.setdefault(i % 30 - n + 1, Pool(1000, FAR_MM)).add(held, real[i])
        result["runs"].append({
            "active_frames": n,
            "synthesized": summary.synthesized,
            "method": summary.method,
            "intrinsics": summary.intrinsics,
            "kept_identical": identical,
            "rmse_cm": ours.rmse_cm(),
            "hold_last_rmse_cm": hold.rmse_cm(),
            "rmse_vs_hold_last": round(ours.rmse_cm() / hold.rmse_cm(), 3),
            "coverage": ours.coverage(),
            "hold_last_coverage": hold.coverage(),
            "coverage_vs_hold_last": round(ours.coverage() / hold.coverage(), 3),
            "rmse_cm_by_frames_since_real": {k: p.rmse_cm() for k, p in sorted(by_gap.items())},
            "hold_last_rmse_cm_by_frames_since_real": {k: p.rmse_cm() for k, p in sorted(hold_gap.items())},
            "frames_per_second": round(len(files) / seconds, 1),
        })  # fmt: skip
        print(result["runs"][-1], flush=True)
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
