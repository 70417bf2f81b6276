"""Probe (issue 80): can the flicker between consecutive frames find continuous-wave ToF interference
without a scene? Per pair of consecutive frames, the returns that moved by ``LOW_M`` to ``HIGH_M`` (the
offsets real Kinect v2 interference makes) and, of those, the ones amid others (half of their 9x9
neighbourhood moved too: patches, not a sensor's speckle). On the real Kinect v2 cam0 frames with the
other two cameras running (``interf``; each frame's pixels moved by more than 2 cm from the median of the
frames alone beside it), on its frames alone (``ref``), and on clean sequences of other sensors: the still
L515 views dev0 and dev1, the hand-held D435.

Run:  python -m lab.tof_flicker --data ../shared/data --json lab/notes/results/tof_flicker.json
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from bench.harness import measure_main

LOW_M, HIGH_M = 0.02, 0.08  # a return moved this much since the frame before
AMID = 41  # of its 9x9 neighbourhood (81), at least this many moved too
SEQUENCES = {  # folder under --data, units per metre
    "kinect2 cam0 interfered": ("kinect2_multicam/cam0/interf", 1000.0),
    "kinect2 cam0 alone": ("kinect2_multicam/cam0/ref", 1000.0),
    "L515 dev0 (still, clean)": ("l515/dev0", 4000.0),
    "L515 dev1 (still, clean)": ("l515/dev1", 4000.0),
    "D435 (hand-held, clean)": ("d435", 1000.0),
}


def flicker(a: np.ndarray, b: np.ndarray) -> tuple[int, int, int]:
    """(returns in both frames, of them moved by LOW_M..HIGH_M, of those amid others) for metres a, b."""
    both = (a > 0) & (b > 0)
    d = np.abs(a - b)
    band = both & (d > LOW_M) & (d < HIGH_M)
    around = cv2.boxFilter(band.view(np.uint8), -1, (9, 9), normalize=False)
    return int(both.sum()), int(band.sum()), int((band & (around >= AMID)).sum())


def _pct(values: list[float]) -> dict[str, float]:
    v = np.asarray(values, float)
    return {f"p{q}": round(float(np.percentile(v, q)), 4) for q in (5, 50, 95)} | {
        "max": round(float(v.max()), 4)
    }


def measure(data: Path) -> tuple[dict, list[Path]]:
    out: dict = {"moved_band_m": [LOW_M, HIGH_M], "amid_of_81": AMID, "sequences": {}}
    read: list[Path] = []
    truth = None
    for name, (folder, scale) in SEQUENCES.items():
        files = sorted((data / folder).glob("*.png"))
        read += files
        frames = [
            cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float32) / np.float32(scale) for f in files
        ]
        if name == "kinect2 cam0 alone":
            truth = np.median(np.stack(frames), axis=0)
        pairs = [flicker(frames[i], frames[i - 1]) for i in range(1, len(frames))]
        out["sequences"][name] = {
            "pairs": len(pairs),
            "dense_pixels": _pct([p[2] for p in pairs]),
            "dense_share_of_returns": _pct([p[2] / max(p[0], 1) for p in pairs]),
            "pairs_with_no_dense_pixel": sum(p[2] == 0 for p in pairs),
        }
    # cam0's truth: the frames with over 100 pixels moved more than 2 cm (issue 80's bar), and what the
    # flicker shows on them
    assert truth is not None
    files = sorted((data / SEQUENCES["kinect2 cam0 interfered"][0]).glob("*.png"))
    frames = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float32) / np.float32(1000) for f in files]
    hit, dense_on_hit = 0, []
    for i in range(1, len(frames)):
        ok = (frames[i] > 0) & (truth > 0)
        moved = int((np.abs(frames[i] - truth)[ok] > 0.02).sum())
        if moved > 100:
            hit += 1
            dense_on_hit.append(flicker(frames[i], frames[i - 1])[2])
    out["kinect2 cam0 frames with over 100 pixels moved (from the second)"] = {
        "frames": hit,
        "dense_pixels": _pct(dense_on_hit),
        "with no dense pixel": sum(d == 0 for d in dense_on_hit),
    }
    return out, read


def main() -> None:
    measure_main(__doc__, measure, "kinect2 cam0 (interfered, alone), L515 dev0 and dev1, D435")


if __name__ == "__main__":
    main()
