"""Issue 80: a detector's verdicts without any scene, on real frames only. The real Kinect v2 interference
(``kinect2_multicam/cam0``): of its interfered frames with more than 100 valid pixels moved by more than
2 cm (against the per-pixel median of the frames alone), the share flagged (recall), with each frame's
score; its 6 frames alone, flagged. Every clean real set in ``../shared/data`` (``real_clean_sets``: L515
dev0/dev1 every third frame, D435, Azure Kinect, TUM, SUN, NYU, other): frames flagged. Frames of a
sequence are scored with the frame delivered before them, as ``d2sr detect --no-scene`` does.

Run:  python -m lab.detector_tof --data ../shared/data [--models out/cand80] --json out.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.contract.catalog import padded
from d2sr.eval.generalization import real_clean_sets
from d2sr.frames.base import to_metres
from d2sr.provenance import data_read
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings
from lab.kinect2_stats import BIG_PATCH, MOVED_MM, _read, truth_of


def _scores(net, frames: list[np.ndarray], scale: float, sequence: bool) -> list[float]:
    out = []
    for k, f in enumerate(frames):
        x = padded(to_metres(f.astype(np.uint16), scale)[None])
        prev = padded(to_metres(frames[k - 1].astype(np.uint16), scale)[None]) if sequence and k else None
        if prev is not None and prev.shape != x.shape:
            prev = None
        out.append(float(net.scores(x, prev)[0]))
    return out


def measure(data: Path, models: Path | None) -> tuple[dict, list[Path]]:
    net = open_backend(RunSettings(**({"models": models} if models else {})), recovery=False)
    cam = data / "kinect2_multicam" / "cam0"
    ref, bad = _read(cam / "ref"), _read(cam / "interf")
    truth = truth_of([d for _, d in ref])
    scores = _scores(net, [x for _, x in bad], 1000.0, True)
    hit = []
    for (_, x), s in zip(bad, scores, strict=True):
        moved = (truth > 0) & (x > 0) & (np.abs(x - truth) > MOVED_MM)
        if int(moved.sum()) > BIG_PATCH:
            hit.append(s)
    alone = _scores(net, [d for _, d in ref], 1000.0, True)
    cut = net.threshold
    real = {}
    for s in real_clean_sets(data):
        sc = _scores(net, s.frames, s.scale, s.sequence)
        real[s.name] = {
            "frames": len(sc),
            "flagged": int(sum(v >= cut for v in sc)),
            "max": round(max(sc), 4),
        }
    result = {
        "threshold": cut,
        "kinect2_cam0": {
            "frames_over_100_moved": len(hit),
            "recall": round(sum(v >= cut for v in hit) / max(len(hit), 1), 4),
            "flagged_of_50": int(sum(v >= cut for v in scores)),
            "scores_over_100_moved": sorted(round(v, 4) for v in hit),
            "alone_flagged": int(sum(v >= cut for v in alone)),
            "alone_max": round(max(alone), 4),
        },
        "clean_real": real,
        "clean_real_flagged": sum(r["flagged"] for r in real.values()),
    }
    return result, [f for f, _ in ref] + [f for f, _ in bad]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--models", type=Path, default=None, help="a folder of models (default: the shipped)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result, read = measure(args.data, args.models)
    result["models_folder"] = str(args.models) if args.models else "shipped"
    data = data_read("kinect2_multicam/cam0 (and the clean real sets, not digested)", read, args.data)
    print(write_result(result, args.json, data=data))


if __name__ == "__main__":
    main()
