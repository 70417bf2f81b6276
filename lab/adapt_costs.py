"""What each part of ``d2sr adapt`` costs on this machine: the figures behind ``d2sr.train.adapt.COSTS``,
which turn a budget into a plan. Run it on an idle 2-core machine:

    python -m lab.adapt_costs --data ../shared/data/d435 --frames 100

It reads the first FRAMES clean frames, then times: corrupting copies (two worker processes), generating
frames, training steps, and judging the held-out frames with the loading and exports (the rest of adapt).
Each figure is the median of REPEATS runs of a fixed amount of work."""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from d2sr.frames.checks import checked_counts, open_input
from d2sr.train import adapt as A


def _timed(fn: Callable[[], object], n: int, repeats: int) -> float:
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        runs.append((time.perf_counter() - t) / n)
    return statistics.median(runs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    files = sorted(args.data.glob("*.png"))[: args.frames]
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "clean"
        src.mkdir()
        for f in files:
            (src / f.name).write_bytes(f.read_bytes())
        reader, scale = open_input(src, None, 1000.0, "clean", 1000.0)
        frames = [f.depth for f in checked_counts(reader, scale, "clean frame")]
        jobs = [(f, scale, A.SEED + i) for i, f in enumerate(frames[:48])]
        with ProcessPoolExecutor(2) as ex:
            list(ex.map(A._corrupt, jobs[:4]))  # workers started
            corrupt = _timed(lambda: list(ex.map(A._corrupt, jobs, chunksize=8)), len(jobs), args.repeats)
            seeds = range(A.REHEARSAL_SEED, A.REHEARSAL_SEED + 24)
            generate = _timed(lambda: list(ex.map(A._generated, seeds, chunksize=8)), 24, args.repeats)
        fit = A._fit
        seconds: dict[str, float] = {}

        def timed_fit(phase, *a, **k):
            t = time.perf_counter()
            r = fit(phase, *a, **k)
            seconds["fit"] = time.perf_counter() - t
            return r

        A._fit = timed_fit
        rest: dict[int, list[float]] = {}
        fits: list[float] = []
        steps = 40
        # two sizes, alternated (the first run also warms up): the fixed part and the part per judged frame
        for k, n in enumerate([len(frames) // 2, len(frames)] * args.repeats):
            _, held = A.split([frames[:n]])
            plan = A.Plan(1, A.HELD_VARIANTS, 0, steps, 0.0)
            data = A.prepare([frames[:n]], scale, plan=plan)
            t = time.perf_counter()
            A.adapt(data, Path(tmp) / f"m{k}", plan, 0.01, "adapt_costs")
            rest.setdefault(held * A.HELD_VARIANTS, []).append(time.perf_counter() - t - seconds["fit"])
            fits.append(seconds["fit"])
    (j1, r1), (j2, r2) = sorted((j, statistics.median(v)) for j, v in rest.items())
    judge = (r2 - r1) / (j2 - j1)
    step = statistics.median(fits) / steps
    print(f"step {step:.4f} s ({1 / step:.1f} steps/s), corrupt {corrupt:.3f} s, generate {generate:.3f} s")
    print(
        f"judge {judge:.3f} s per judged frame, fixed {r1 - judge * j1:.1f} s "
        f"(judged {j1}: {r1:.1f} s, {j2}: {r2:.1f} s)"
    )


if __name__ == "__main__":
    main()
