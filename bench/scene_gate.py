"""Benchmark (issue 42): the scene's stillness gate (``d2sr.reference.STILL_SHARE``) on a set of
``held_out.py``, every other frame corrupted: per part, the flags of ``SensorLoop`` (``repair="none"``, as
``bench/scene_reference.py`` runs it) with the detector alone, with the scene ungated
(``SceneReference(still_share=None)``, ``--scene`` before the gate) and with the scene as shipped (gated).

Parts: ``d435``, the hand-held D435 whole (193 frames at 1000 units a metre, a moving sensor, one
sequence); ``l515``, the outside set's 120 L515 frames, each view a cold sequence of 60. ``--set k``: set K,
written and sealed for this measurement and opened by it on 2026-11-27; the rule it judged is in
docs/research/decisions.md, and the result says whether it held (it did).

Run:  .venv/bin/python bench/scene_gate.py --set k --data ../shared/data --json docs/results/scene_gate_k.json
"""

from __future__ import annotations

import argparse
from functools import partial
from pathlib import Path

import numpy as np

import d2sr.runtime.loop as loop_module
from d2sr.bench import check_output, output_args, write_result
from d2sr.contract import DETECTOR
from d2sr.desync import make_controller
from d2sr.errors import D2SRError
from d2sr.frames import Frame, open_frames
from d2sr.reference import STILL_FRAMES, STILL_MIN, STILL_Q, STILL_SHARE, SceneReference
from d2sr.runtime.backends import Backend, open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from held_out import KINDS, SETS, every_other, outside_set, set_data

MODES = ("detector", "scene ungated", "scene gated (shipped)")


def flags(net: Backend, frames: list[np.ndarray], scale: float, mode: str) -> np.ndarray:
    """The loop's flag on each frame, in order, from a cold start."""
    gate = None if mode == "scene ungated" else STILL_SHARE
    loop_module.SceneReference = partial(SceneReference, still_share=gate)  # type: ignore[misc]
    try:
        lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=mode != "detector")
        return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])
    finally:
        loop_module.SceneReference = SceneReference  # type: ignore[misc]


def rates(f: np.ndarray, hit: np.ndarray) -> dict:
    tp = int((f & hit).sum())
    return {
        "precision": round(tp / max(int(f.sum()), 1), 3),
        "recall": round(tp / max(int(hit.sum()), 1), 3),
        "clean_flagged": int((f & ~hit).sum()),
        "clean": int((~hit).sum()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--set", dest="which", default="k", choices=sorted(SETS))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    try:
        net = open_backend(None, "onnx")
        d435 = [f.depth for f in open_frames(args.data / "d435")]
    except D2SRError as exc:
        ap.error(str(exc))
    l515 = outside_set(args.data)
    parts = {
        "d435": ([every_other(d435, 1000.0, args.which)], [d435], 1000.0),
        "l515": (
            [every_other(l515[a : a + 60], 4000.0, args.which) for a in (0, 60)],
            [l515[:60], l515[60:]],
            4000.0,
        ),
    }
    result: dict = {"benchmark": "issue 42: the scene's stillness gate", "parts": {}}
    for part, (seqs, cleans, scale) in parts.items():
        hit = np.concatenate(
            [
                [bool((b != c).any()) for b, c in zip(s, k, strict=True)]
                for s, k in zip(seqs, cleans, strict=True)
            ]
        )
        result["parts"][part] = {
            mode: rates(np.concatenate([flags(net, s, scale, mode) for s in seqs]), hit) for mode in MODES
        }
    moving, still = result["parts"]["d435"], result["parts"]["l515"]
    det, ungated, gated = MODES
    result["rule"] = {
        "1 d435: clean flags at most detector + 1, recall at least detector - 0.02": bool(
            moving[gated]["clean_flagged"] <= moving[det]["clean_flagged"] + 1
            and moving[gated]["recall"] >= moving[det]["recall"] - 0.02
        ),
        "2 l515: recall at least ungated - 0.02, clean flags at most ungated + 1": bool(
            still[gated]["recall"] >= still[ungated]["recall"] - 0.02
            and still[gated]["clean_flagged"] <= still[ungated]["clean_flagged"] + 1
        ),
    }
    result["gate"] = {
        "still_share": STILL_SHARE,
        "still_q": STILL_Q,
        "still_frames": STILL_FRAMES,
        "still_min": STILL_MIN,
    }
    data = {
        "set": f"set {args.which.upper()} ({', '.join(KINDS[args.which])}), bench/held_out.py, "
        "every other frame",
        "frames": "the hand-held D435 (193), and 120 real L515 frames (dev0 after the person has left, dev1)",
        "status": set_data(args.which)["status"],
    }
    print(write_result(result, args.json, models=[DETECTOR], data=data))


if __name__ == "__main__":
    main()
