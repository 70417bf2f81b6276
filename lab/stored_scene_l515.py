"""Probe (issue 65): a stored scene on the real L515 views, where the scene primed on the frames was judged
until now. Each view's scene is learned (``learn_scene``) from clean frames of that view the judged frames
do not include: dev0 from its frames 120 on (the person has left), dev1 from its frames 60 on. Then, with
``scene_from`` (no priming, as ``d2sr detect --scene-from`` runs):

* clean: dev0 frames 0-119 (a person walks through its first frames) and dev1 frames 0-59: frames flagged;
* the outside sets A-I (``held_out.every_other`` on dev0 60-119 and dev1 0-59): precision and recall, mean
  and worst, beside the primed scene's in the same run.

Run:  python -m lab.stored_scene_l515 --data ../shared/data [--json out.json]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args

from d2sr.desync import make_controller
from d2sr.eval.speed import write_result
from d2sr.frames import Frame
from d2sr.runtime.backends import Backend, open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import RunSettings
from d2sr.scene.stored import learn_scene
from lab.held_out import every_other, open_sets

SCALE = 4000.0
# (view, frames judged, frames the stored scene is learned from): disjoint.
VIEWS = {"dev0": (slice(0, 120), slice(120, None)), "dev1": (slice(0, 60), slice(60, None))}


def _frames(data: Path, view: str) -> list[np.ndarray]:
    files = sorted((data / "l515" / view).glob("*.png"))
    return [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files]


def flags(net: Backend, frames: list[np.ndarray], scene: Path | None) -> np.ndarray:
    """Each frame's verdict, in order: with the stored scene ``scene``, or primed on the frames (None)."""
    loop = SensorLoop(
        net, make_controller("static", 30, 30), settings=RunSettings(repair="none", scene_from=scene)
    )
    caps = (Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames))
    if scene is None:
        caps = loop.primed(caps)
    return np.array([loop.process(c).flagged for c in caps])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    net = open_backend(RunSettings(backend="onnx"), recovery=False)
    views = {v: _frames(args.data, v) for v in VIEWS}
    result: dict = {"clean": {}, "outside": {}}
    with tempfile.TemporaryDirectory() as tmp:
        scenes = {}
        for v, (_, learn) in VIEWS.items():
            clean = views[v][learn]
            scenes[v] = Path(tmp) / f"{v}.npz"
            learn_scene(lambda c=clean: iter(c), SCALE, v, len(clean)).save(scenes[v])
            judged = views[v][VIEWS[v][0]]
            result["clean"][v] = {
                "stored": f"{int(flags(net, judged, scenes[v]).sum())} of {len(judged)}",
                "primed": f"{int(flags(net, judged, None).sum())} of {len(judged)}",
                "learned_from": len(clean),
            }
        # The outside sets' views: dev0 60-119 (after the person), dev1 0-59.
        parts = {"dev0": views["dev0"][60:120], "dev1": views["dev1"][0:60]}
        for which in open_sets():
            out = {}
            for how in ("stored", "primed"):
                tp = fp = pos = 0
                for v, clean in parts.items():
                    bad = every_other(clean, SCALE, which)
                    hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
                    f = flags(net, bad, scenes[v] if how == "stored" else None)
                    tp, fp, pos = tp + int((f & hit).sum()), fp + int((f & ~hit).sum()), pos + int(hit.sum())
                out[how] = {"precision": round(tp / max(tp + fp, 1), 3), "recall": round(tp / max(pos, 1), 3)}
            result["outside"][which] = out
    sets = result["outside"].values()
    result["mean_worst"] = {
        how: {
            m: {
                "mean": round(float(np.mean([s[how][m] for s in sets])), 3),
                "worst": min(s[how][m] for s in sets),
            }
            for m in ("precision", "recall")
        }
        for how in ("stored", "primed")
    }
    print(write_result(result, args.json, data="real L515 dev0/dev1; outside sets A-I"))


if __name__ == "__main__":
    main()
