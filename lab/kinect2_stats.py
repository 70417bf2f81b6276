"""What real continuous-wave ToF interference looks like (issue 80's reference for a generator): the Kinect
v2 multi-camera recording (``kinect2_multicam/cam0``), each of its 50 interfered frames against the
per-pixel median of its 6 frames alone. Per frame: the share of valid pixels moved by more than 2 cm, and
of those the offsets (interfered minus truth, mm); pooled: offset percentiles, how the moved pixels group
(8-connected patches: area percentiles, the share of moved pixels in patches of at least 100 pixels, the
share of patches whose offsets keep one sign), and how the moved pixels persist from one frame to the next
(intersection over union of consecutive frames' masks). A generator of CW-ToF interference is measured
against these before a detector trains on it.

Run:  python -m lab.kinect2_stats --data ../shared/data --json lab/notes/results/kinect2_stats.json
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from bench.harness import measure_main

MOVED_MM = 20  # a pixel moved: more than 2 cm off the truth (as lab.kinect2_cam0 counts)
BIG_PATCH = 100  # pixels: a patch the detector's bar counts (issue 80: frames with > 100 pixels moved)


def _read(folder: Path) -> list[tuple[Path, np.ndarray]]:
    return [
        (f, cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float32)) for f in sorted(folder.glob("*.png"))
    ]


def _pct(values: np.ndarray, qs: tuple[int, ...] = (5, 25, 50, 75, 95)) -> dict[str, float]:
    if values.size == 0:
        return {}
    return {f"p{q}": round(float(np.percentile(values, q)), 1) for q in qs}


def describe(truth: np.ndarray, frames: list[np.ndarray]) -> dict:
    """The figures below for interfered ``frames`` (mm, float) against one ``truth`` (mm, 0: none), or
    against one truth each when ``truth`` is a stack of them."""
    offsets, shares, areas, one_sign, big, total, ious = [], [], [], 0, 0, 0, []
    patches = 0
    last = None
    for k, x in enumerate(frames):
        t = truth[k] if truth.ndim == 3 else truth
        valid = (t > 0) & (x > 0)
        off = x - t
        moved = valid & (np.abs(off) > MOVED_MM)
        shares.append(float(moved.sum()) / max(float(valid.sum()), 1.0))
        offsets.append(off[moved])
        n, labels, stats, _ = cv2.connectedComponentsWithStats(moved.astype(np.uint8), connectivity=8)
        for j in range(1, n):
            area = int(stats[j, cv2.CC_STAT_AREA])
            areas.append(area)
            total += area
            if area >= BIG_PATCH:
                big += area
                signs = np.sign(off[labels == j])
                one_sign += int(abs(signs.sum()) >= 0.9 * signs.size)
                patches += 1
        if last is not None:
            union = float((moved | last).sum())
            ious.append(float((moved & last).sum()) / union if union else 1.0)
        last = moved
    pooled = np.concatenate(offsets) if offsets else np.zeros(0)
    return {
        "frames": len(frames),
        "moved_mm": MOVED_MM,
        "share_moved": {"mean": round(float(np.mean(shares)), 4), **_pct(np.array(shares) * 100)},
        "share_moved_pct_note": "percentiles of the share moved are in percent of a frame's valid pixels",
        "frames_over_100_moved": int(sum(len(o) > BIG_PATCH for o in offsets)),
        "offsets_mm": {
            "count": int(pooled.size),
            "negative": round(float((pooled < 0).mean()), 3) if pooled.size else None,
            **_pct(pooled),
        },
        "patch_area_px": {"count": len(areas), **_pct(np.array(areas, float))},
        "share_in_patches_of_100_or_more": round(big / max(total, 1), 3),
        "patches_of_100_or_more_one_sign": round(one_sign / max(patches, 1), 3),
        "consecutive_iou": {"mean": round(float(np.mean(ious)), 3), **_pct(np.array(ious))} if ious else {},
    }


def truth_of(ref: list[np.ndarray]) -> np.ndarray:
    """The camera alone: the per-pixel median of its frames where at least 4 of 6 have a return."""
    stack = np.stack(ref)
    truth = np.where((stack > 0).sum(0) >= 4, np.median(np.where(stack > 0, stack, np.nan), axis=0), 0)
    return np.nan_to_num(truth)


def measure(data: Path) -> tuple[dict, list[Path]]:
    cam = data / "kinect2_multicam" / "cam0"
    ref, bad = _read(cam / "ref"), _read(cam / "interf")
    result = describe(truth_of([d for _, d in ref]), [x for _, x in bad])
    return result, [f for f, _ in ref] + [f for f, _ in bad]


def main() -> None:
    measure_main(__doc__, measure, "kinect2_multicam/cam0: 50 interfered frames, 6 alone")


if __name__ == "__main__":
    main()
