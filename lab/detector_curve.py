"""Benchmark: the shipped detector's share of frames flagged per threshold, on the frames each outside set
of ``held_out.py`` changed (recall) and on the clean real sequences (false alarms: L515 dev0 after the
person has left and all of dev1, the D435 sequence at its scale), each in order so that the detector weighs
the frame before as ``d2sr detect`` does. Shows whether a missed outside set is a threshold away or not.

Run:  python -m lab.detector_curve --json docs/results/detector_curve.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args

from d2sr.contract.catalog import THRESHOLD
from d2sr.errors import D2SRError
from d2sr.eval.speed import write_result
from d2sr.frames import open_frames
from d2sr.runtime.backends import Backend, open_backend
from lab.held_out import every_other, open_sets, outside_set

THRESHOLDS = (0.9, 0.7, THRESHOLD, 0.4, 0.3, 0.2, 0.1, 0.05)


def scores(net: Backend, frames: list[np.ndarray], scale: float) -> np.ndarray:
    """The detector's score of each frame, given the frame before (none for the first)."""
    out, prev = [], None
    for f in frames:
        x = f.astype(np.float32)[None] / np.float32(scale)
        out.append(float(net.scores(x, prev)[0]))
        prev = x
    return np.array(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    try:
        net = open_backend(None, "onnx")
    except D2SRError as exc:
        ap.error(str(exc))
    clean = outside_set(args.data)
    sets: dict[str, np.ndarray] = {}
    for which in open_sets():
        bad = every_other(clean, 4000.0, which)
        hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
        sets[f"outside set {which} (recall)"] = scores(net, bad, 4000.0)[hit]
    try:
        dev0, dev1, d435 = (
            [f.depth for f in open_frames(args.data / p)] for p in ("l515/dev0", "l515/dev1", "d435")
        )
    except D2SRError as exc:
        ap.error(str(exc))
    sets["clean L515 (false alarms)"] = scores(net, dev0[45:] + dev1, 4000.0)
    sets["clean D435 (false alarms)"] = scores(net, d435, 1000.0)
    result = {
        "frames": {k: len(v) for k, v in sets.items()},
        "flagged": {
            f"{t:g}": {k: round(float((v >= t).mean()), 4) for k, v in sets.items()} for t in THRESHOLDS
        },
        "shipped_threshold": THRESHOLD,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
