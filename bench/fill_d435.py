"""Benchmark: ``d2sr fill`` on the real hand-held D435 RGB-D sequence (``../shared/data/d435``, depth aligned
to colour), keeping slots 0..n-1 of every 30, against holding the last kept frame.

For each n: the RMSE of the synthesized frames against the real frames they replace, over pixels where
both have valid depth under 8 m (pooled over frames), and the coverage: the share of the real frames'
valid pixels the synthesized frames give a value; the same for hold-last; the ratios the issue's bar
reads (RMSE at most 50% of hold-last's, coverage at least 90% of hold-last's); kept frames bit-identical;
the RMSE by frames since the last real one (the paper's Fig. 11); frames a second.

Run:  .venv/bin/python bench/fill_d435.py --data ../shared/data --json docs/results/fill_d435.json
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

import cv2
import numpy as np

from d2sr.bench import check_output, cpu, output_args, write_result
from d2sr.synth import fill_recording

HERE = Path(__file__).resolve().parents[1]
FAR_MM = 8000


def read(p: Path) -> np.ndarray:
    return cv2.imread(str(p), cv2.IMREAD_UNCHANGED).astype(np.float64)


class Pool:
    """Pooled squared error and counts."""

    def __init__(self) -> None:
        self.se = self.both = self.real = 0.0

    def add(self, pred: np.ndarray, real: np.ndarray) -> None:
        ok = (real > 0) & (real < FAR_MM)
        both = ok & (pred > 0) & (pred < FAR_MM)
        self.se += float((((pred - real) / 1000)[both] ** 2).sum())
        self.both += float(both.sum())
        self.real += float(ok.sum())

    def rmse_cm(self) -> float:
        return round(100 * float(np.sqrt(self.se / max(self.both, 1))), 2)

    def coverage(self) -> float:
        return round(self.both / max(self.real, 1), 4)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap, plot="RMSE by frames since the last real one (the paper's Fig. 11), PNG")
    args = ap.parse_args()
    check_output(ap, args)
    seq = args.data / "d435"
    files = sorted(seq.glob("depth*.png"))
    real = [read(f) for f in files]
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=HERE).stdout
    result: dict = {
        "command": "python bench/fill_d435.py " + " ".join(sys.argv[1:]),
        "commit": commit.strip(),
        "cpu": cpu(),
        "date": datetime.now(UTC).strftime("%Y-%m-%d"),
        "data": f"{seq} ({len(files)} frames, hand-held D435, depth aligned to colour; development sequence)",
        "runs": [],
    }
    for n in (15, 6):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "filled"
            t = time.perf_counter()
            summary = fill_recording(seq, out, n, rgb=seq / "rgb")
            seconds = time.perf_counter() - t
            ours, hold = Pool(), Pool()
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
                by_gap.setdefault(i % 30 - n + 1, Pool()).add(got, real[i])
                hold_gap.setdefault(i % 30 - n + 1, Pool()).add(held, real[i])
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
        plot(result, args.plot)


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from d2sr.eval.plots import save

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for run in result["runs"]:
        gaps = sorted(run["rmse_cm_by_frames_since_real"], key=int)
        ax.plot([int(g) for g in gaps], [run["rmse_cm_by_frames_since_real"][g] for g in gaps], marker="o",
                ms=3, label=f"d2sr fill, {run['active_frames']} of 30 kept")  # fmt: skip
        held = run["hold_last_rmse_cm_by_frames_since_real"]
        colour = ax.lines[-1].get_color()
        ax.plot([int(g) for g in gaps], [held[g] for g in gaps], ls="--", lw=1, color=colour,
                label=f"hold-last, {run['active_frames']} of 30 kept")  # fmt: skip
    ax.set(xlabel="frames since the last real frame", ylabel="RMSE (cm)", ylim=(0, None),
           title="Synthesized frames against the real ones, hand-held D435")  # fmt: skip
    ax.legend(fontsize=7)
    fig.text(0.01, -0.06, result["command"], fontsize=6)
    save(fig, path)


if __name__ == "__main__":
    main()
