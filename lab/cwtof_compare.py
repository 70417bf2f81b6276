"""Issue 80: the CW-ToF interference generator (``d2sr.sim.cwtof``) against the real Kinect v2 recording,
before any detector trains on it. The generator interferes with cam0's own frames alone (``ref/``, each
its own truth; frame ``k`` of ``--frames`` is ref frame ``k mod 6`` with seed ``k``), as a Kinect v2 beside
one or two others, and the same figures are taken of both (``lab.kinect2_stats.describe``): the share of
valid pixels moved by more than 2 cm, the offsets, the patches and how they persist.

The recording's authors removed its background (everything outside a box about the mannequin reads 0), so
a generated depth that leaves the truth's depth range by more than ``--box`` metres reads 0 here too, as it
would there: a wrong wrap, metres away, is not seen as a moved pixel in the real frames either. The
generator's frames are independent draws, not a sequence: their persistence is for reference only.

Run:  python -m lab.cwtof_compare --data ../shared/data --json lab/notes/results/cwtof_compare.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.provenance import data_read
from d2sr.sim.cwtof import KINECT2, cw_tof_interference
from lab.kinect2_stats import _read, describe, truth_of


def generated(ref: list[np.ndarray], frames: int, box_m: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """(truths, interfered frames) in mm, as described above."""
    truths, out = [], []
    for k in range(frames):
        clean = ref[k % len(ref)]
        frame, _ = cw_tof_interference(clean.astype(np.uint16), 1000.0, k, KINECT2)
        x = frame.astype(np.float32)
        lo, hi = clean[clean > 0].min() - 1000 * box_m, clean.max() + 1000 * box_m
        truths.append(clean)
        out.append(np.where((x >= lo) & (x <= hi), x, 0))
    return np.stack(truths), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=200, help="generated frames")
    ap.add_argument("--box", type=float, default=0.3, help="metres beyond the truth's range that read 0")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    cam = args.data / "kinect2_multicam" / "cam0"
    ref, bad = _read(cam / "ref"), _read(cam / "interf")
    truths, frames = generated([d for _, d in ref], args.frames, args.box)
    result = {
        "generator": "d2sr.sim.cwtof, camera kinect2 (80/16/120 MHz), one or two others of its model",
        "real": describe(truth_of([d for _, d in ref]), [x for _, x in bad]),
        "generated": describe(truths, frames),
        "box_m": args.box,
    }
    read = [f for f, _ in ref] + [f for f, _ in bad]
    print(write_result(result, args.json, data=data_read("kinect2_multicam/cam0", read, args.data)))


if __name__ == "__main__":
    main()
