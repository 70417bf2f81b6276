"""Benchmark: ``d2sr recover --repair all`` from outside the process, this checkout against another commit, in one
run: the worst case for speed (real 640x480 L515 frames, every one corrupted by the outside interference
of ``bench.outside``, so both passes run on every frame); ``--flagged``: without ``--repair all`` (the detector runs,
and repairs what it flags); ``--model``: another recovery model than the default. Runs alternate between
the two trees so that a shared, noisy machine slows both alike; per tree, the median over ``--runs`` of
(60 frames - 10 frames) / 50 is the time a frame takes without start-up. Also checks that both write the
same repaired frames and masks.

Run:  python -m lab.against --ref b1062a7 --data ../shared/data \
          --json lab/notes/results/bench_against.json
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import worst_case

from d2sr.atomic import write_result

HERE = Path(__file__).resolve().parents[1]


def _recover(src: Path, frames: Path, out: Path, options: list[str]) -> float:
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, "-m", "d2sr", "recover", str(frames), *options, "--depth-scale", "4000"]
    cmd += ["--out", str(out)]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} ({src}) failed: {r.stderr.strip()}")
    return time.perf_counter() - t


def write_inputs(root: Path, frames: list[tuple[str, np.ndarray]]) -> None:
    """``root/in10`` and ``root/in60``: the first 10 and 60 frames (name, frame) as PNG files."""
    for n in (10, 60):
        (root / f"in{n}").mkdir()
        for name, frame in frames[:n]:
            cv2.imwrite(str(root / f"in{n}" / name), frame)


def fps(secs60: list[float], secs10: list[float]) -> float:
    """Frames a second without start-up: the medians' difference over the 50 frames between the runs."""
    return round(50 / (statistics.median(secs60) - statistics.median(secs10)), 1)


def _same(a: Path, b: Path) -> bool:
    for f in sorted(a.glob("*.png")):
        for sub in ("", "masks"):
            x, y = (cv2.imread(str(d / sub / f.name), cv2.IMREAD_UNCHANGED) for d in (a, b))
            if x is None or y is None or not np.array_equal(x, y):
                return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref", required=True, help="the commit to compare with (git rev)")
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument(
        "--flagged", action="store_true", help="recover without --repair all: the detector's path"
    )
    ap.add_argument("--model", default=None, help="recover's --model in both trees (default: their own)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    frames = worst_case(args.data)
    options = [] if args.flagged else ["--repair", "all"]
    options += ["--model", args.model] if args.model else []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        ref = root / "ref"
        git = ["git", "-C", str(HERE), "worktree"]
        subprocess.run([*git, "add", "--detach", str(ref), args.ref], check=True)
        try:
            write_inputs(root, frames)
            trees = {"this": HERE / "src", args.ref: ref / "src"}
            secs: dict[tuple[str, int], list[float]] = {}
            for k in range(args.runs):
                for j, (name, src) in enumerate(trees.items()):
                    for n in (60, 10):
                        out = root / f"out{j}-{n}-{k}"
                        secs.setdefault((name, n), []).append(_recover(src, root / f"in{n}", out, options))
                        took = secs[(name, n)][-1]
                        print(f"run {k + 1}/{args.runs} {name} {n} frames: {took:.2f} s", flush=True)
            same = _same(root / "out0-60-0", root / "out1-60-0")
        finally:
            subprocess.run([*git, "remove", "--force", str(ref)], check=False)
    rate = {name: fps(secs[(name, 60)], secs[(name, 10)]) for name in trees}
    result = {
        "measured": " ".join(["d2sr recover IN", *options, "--depth-scale 4000 --out OUT"]),
        "frames": "60 vs 10 L515 dev1 frames, every one corrupted by bench.outside's outside_interference",
        "ref": args.ref,
        "runs": args.runs,
        "seconds": {f"{name} {n}": [round(s, 3) for s in v] for (name, n), v in secs.items()},
        "fps": rate,
        "speedup": round(rate["this"] / rate[args.ref], 3),
        "identical_output": same,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
