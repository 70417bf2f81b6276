"""Interference that repeats at one place (issue 77): real L515 frames (``l515/dev0``, ``dev1``, 45 frames from
frame 60) through ``d2sr.Pipeline`` as shipped, a band of rows 200-240 (columns 100-500) interfered in every
other frame or in two of three, read off by a few or tens of centimetres either way, thinned out (70% of its
returns dropped) or speckled (30% of its pixels a stray return 0.5-2 m). Per case: clean frames that came
back changed (the bar: none), and interfered frames flagged.

Run:  python -m lab.repeating --data ../shared/data [--json out.json]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import cv2
import numpy as np

CASES = (("shift", -0.05), ("shift", 0.05), ("shift", -0.3), ("shift", 0.6), ("drop", 0.0), ("speck", 0.0))


def _frame(path: Path, k: int, every: int, kind: str, metres: float) -> tuple[np.ndarray, bool]:
    f = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    hit = k % every != 0
    if hit:
        g = f.astype(np.int32)
        band = g[200:240, 100:500]
        rng = np.random.default_rng(k)
        if kind == "shift":
            band[band > 0] += round(metres * 4000)
        elif kind == "drop":
            band[rng.random(band.shape) < 0.7] = 0
        else:
            m = rng.random(band.shape) < 0.3
            band[m] = rng.integers(2000, 8000, int(m.sum()))
        f = np.clip(g, 0, 65535).astype(np.uint16)
    return f, hit


def run(files: list[Path], every: int, kind: str, metres: float) -> dict[str, int]:
    import d2sr

    pipe = d2sr.Pipeline(depth_scale=4000)
    out = {"clean": 0, "clean_changed": 0, "interfered": 0, "interfered_flagged": 0}
    for k, path in enumerate(files):
        f, hit = _frame(path, k, every, kind, metres)
        r = pipe.process(f)
        if hit:
            out["interfered"] += 1
            out["interfered_flagged"] += int(r.interfered)
        else:
            out["clean"] += 1
            out["clean_changed"] += int(not np.array_equal(r.depth, f))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")  # the depth-scale doubts of single frames
    result: dict[str, dict[str, int]] = {}
    read: list[Path] = []
    for view in ("dev0", "dev1"):
        files = sorted((args.data / "l515" / view).glob("*.png"))[60:105]
        read += files
        for every in (2, 3):
            for kind, metres in CASES:
                name = f"{view}, 1 in {every} clean, {kind} {metres:+g} m"
                result[name] = run(files, every, kind, metres)
                print(name, result[name], flush=True)
    if args.json:
        if args.json.exists() and not args.overwrite:
            raise SystemExit(f"{args.json} exists; pass --overwrite")
        from d2sr.atomic import write_result
        from d2sr.provenance import data_read

        data = data_read("l515/dev0, l515/dev1: frames 60-104", read, args.data)
        write_result(result, args.json, data=data)


if __name__ == "__main__":
    main()
