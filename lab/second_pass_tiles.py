"""Probe (issue 44): would a second repair pass over only the tiles the first pass touched pay? On the worst
case's frames (``bench.outside``'s ``worst_case``: 60 real L515 frames, every one corrupted), the share of the frame
that 32x32 tiles within ``--margin`` pixels of the first pass's guarded repair cover (``contract.refill``'s
``keep``, what the second pass sees changed). The second pass would run on those tiles plus the model's
reach around them.

Run:  python -m lab.second_pass_tiles --data ../shared/data \\
          --json lab/notes/results/second_pass_tiles.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import worst_case

from d2sr.atomic import write_result
from d2sr.contract.catalog import padded
from d2sr.contract.repair import refill
from d2sr.frames.base import to_metres
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import RunSettings

TILE = 32


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--margin", type=int, default=32, help="pixels around the repaired ones")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    net = open_backend(RunSettings(model="unet8", threads=1), detector=False)
    kept, tiles = [], []
    for _, frame in worst_case(args.data):
        metres = padded(to_metres(frame, 4000.0)[None])
        logit, pred = net.raw(metres)
        _, keep = refill(metres, pred, logit > net.mask_logit)
        k = keep[0]
        near = cv2.dilate(k.astype(np.uint8), np.ones((2 * args.margin + 1,) * 2, np.uint8))
        h, w = near.shape
        touched = near.reshape(h // TILE, TILE, w // TILE, TILE).any(axis=(1, 3))
        kept.append(float(k.mean()))
        tiles.append(float(touched.mean()))
    result = {
        "probe": "issue 44: share of a worst-case frame a tile-limited second pass would cover",
        "frames": len(tiles),
        "model": "unet8 (onnxruntime), its first pass and the guard",
        "tile_px": TILE,
        "margin_px": args.margin,
        "repaired_share": {
            "median": round(float(np.median(kept)), 4),
            "mean": round(float(np.mean(kept)), 4),
        },
        "tiles_share": {
            "median": round(float(np.median(tiles)), 3),
            "mean": round(float(np.mean(tiles)), 3),
            "min": round(float(np.min(tiles)), 3),
        },
    }
    data = f"{args.data}/l515/dev1 (60 real frames with bench.outside's outside_interference)"
    print(write_result(result, args.json, models=["unet8"], data=data))


if __name__ == "__main__":
    main()
