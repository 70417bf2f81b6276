"""Probe (issue 42, do no harm): what ``recover --repair all`` does to clean real L515 frames with and without the
guard's lone-return rule (``contract.LONE_MAX``): returns moved by more than 5 cm and by more than 30 cm,
and dropouts filled, on the 120 clean frames of the outside sets (``bench.outside``'s ``outside_set``).

Run:  python -m lab.lone_returns --data ../shared/data \\
          --json lab/notes/results/lone_returns.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import outside_set, used_models

import d2sr
from d2sr import contract
from d2sr.atomic import write_result


def probe(frames: list[np.ndarray]) -> dict:
    moved5 = moved30 = filled = 0
    for c in frames:
        out = d2sr.repair(c, depth_scale=4000, repair="all").depth.astype(np.int64)
        diff = np.abs(out - c)
        moved5 += int(((c > 0) & (diff > 200)).sum())
        moved30 += int(((c > 0) & (diff > 1200)).sum())
        filled += int(((c == 0) & (out > 0)).sum())
    n = len(frames)
    return {
        "returns_moved_5cm": moved5,
        "returns_moved_30cm": moved30,
        "dropouts_filled": filled,
        "per_frame": {"moved_5cm": round(moved5 / n, 2), "moved_30cm": round(moved30 / n, 2)},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    frames = outside_set(args.data)
    shipped = contract.LONE_MAX
    result: dict = {"frames": len(frames), "lone_max": shipped}
    contract.LONE_MAX = -1  # no return is lone: the rule off
    result["without the rule"] = probe(frames)
    contract.LONE_MAX = shipped
    result["with it (shipped)"] = probe(frames)
    data = (
        f"{args.data}/l515: the 120 clean frames of the outside sets (dev0 after the person has left, dev1)"
    )
    print(write_result(result, args.json, models=used_models("unet8"), data=data))


if __name__ == "__main__":
    main()
