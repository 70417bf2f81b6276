"""Benchmark: ``d2sr recover --repair all``'s worst case from outside the process (``against.py``'s frames: 640x480
L515 frames, every one corrupted by ``bench.outside``'s outside interference) for several recover option
sets in one run on one tree, alternating between them so that a shared, noisy machine slows all alike; per
option set the median over ``--runs`` of (60 frames - 10 frames) / 50 is the time a frame takes without
start-up. For weighing a model or threshold against the default on the speed bar (30 fps).

Run:  python -m lab.model_speed --json docs/results/bench_model_speed.json
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from bench.harness import check_output, output_args
from bench.outside.sets import worst_case

from d2sr.atomic import write_result
from lab.against import HERE, _recover, fps, write_inputs

# name: recover's options after --repair all (the default first: the one the others are compared with)
# (Until 2026-11-26 the default was unet8 and "auto" had its own entry: bench_model_speed_2026-11-26.json.)
OPTIONS = {
    "default": [],
    "unet8": ["--model", "unet8"],
    "auto, mask logit -1.5": ["--model", "auto", "--mask-logit", "-1.5"],
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--runs", type=int, default=5)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    if args.runs < 1:
        ap.error("--runs must be at least 1")
    frames = worst_case(args.data)
    secs: dict[tuple[str, int], list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        write_inputs(root, frames)
        for k in range(args.runs):
            for j, (name, options) in enumerate(OPTIONS.items()):
                for n in (60, 10):
                    out = root / f"out{j}-{n}-{k}"
                    took = _recover(HERE / "src", root / f"in{n}", out, ["--repair", "all", *options])
                    secs.setdefault((name, n), []).append(took)
                    print(f"run {k + 1}/{args.runs} {name} {n} frames: {took:.2f} s", flush=True)
    rate = {name: fps(secs[(name, 60)], secs[(name, 10)]) for name in OPTIONS}
    result = {
        "measured": "d2sr recover IN --repair all OPTIONS --depth-scale 4000 --out OUT",
        "options": {name: " ".join(o) for name, o in OPTIONS.items()},
        "frames": "60 vs 10 L515 dev1 frames, every one corrupted by bench.outside's outside_interference",
        "runs": args.runs,
        "seconds": {f"{name} {n}": [round(s, 3) for s in v] for (name, n), v in secs.items()},
        "fps": rate,
        "ratio_to_default": {name: round(f / rate["default"], 3) for name, f in rate.items()},
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
