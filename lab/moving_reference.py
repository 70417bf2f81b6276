"""Benchmark (issue 42): the moving-sensor scene reference. ``d2sr.Pipeline`` runs the simulator's moving
robot (``lab/moving_set.py``) frame by frame, each with its odometry: the shipped detector alone, and with
``scene=True`` (each frame also judged against the last clean frame warped into its view). Reports per set
the loop's precision and recall over the corrupted frames, the clean frames flagged, and the CPU a frame
costs each way (median over the set's frames, one thread for the detector as shipped).

Run:  python -m lab.moving_reference --set dev --json lab/notes/results/moving_dev.json
Set ``j`` is sealed: its rule is in lab/notes/decisions.md (2026-11-27).
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench.harness import check_output, output_args

from d2sr.eval.speed import write_result
from d2sr.runtime.pipeline import Pipeline
from lab.held_out import used_models
from lab.moving_set import SEEDS, sequences


def run(which: str, scene: bool) -> dict:
    """The loop's verdicts over every sequence of the set."""
    tp = fp = fn = tn = 0
    cpu: list[float] = []
    for seq in sequences(which):
        first = seq[0]
        pipe = Pipeline(first.scale, active_frames=30, controller="static", scene=scene,
                        intrinsics=first.intrinsics)  # fmt: skip
        pipe.loop.moving_scene = scene  # experimental, off in the library since set J
        for shot in seq:
            t = time.process_time()
            flagged = pipe.process(shot.depth, pose=shot.pose).interfered
            cpu.append(1000 * (time.process_time() - t))
            bad = bool(shot.interfered)
            tp += flagged and bad
            fp += flagged and not bad
            fn += not flagged and bad
            tn += not flagged and not bad
    return {
        "precision": round(tp / max(tp + fp, 1), 3),
        "recall": round(tp / max(tp + fn, 1), 3),
        "clean_flagged": f"{fp} of {fp + tn}",
        "clean_flagged_share": round(fp / max(fp + tn, 1), 4),
        "corrupted": tp + fn,
        "cpu_ms_per_frame": round(statistics.median(cpu), 2),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=sorted(SEEDS), default="dev")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result = {"set": args.set, "seeds": list(SEEDS[args.set])}
    for name, scene in (("detector", False), ("detector + moving scene", True)):
        result[name] = run(args.set, scene)
        print(name, result[name], flush=True)
    print(
        write_result(
            result, args.json, models=used_models(None), data=f"simulator, moving robot, set {args.set}"
        )
    )


if __name__ == "__main__":
    main()
