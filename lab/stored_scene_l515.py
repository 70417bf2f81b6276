"""Probe (issue 65): a stored scene on the real L515 views, where the scene primed on the frames was judged
until now. Each view's scene is learned (``learn_scene``) from clean frames of that view the judged frames
do not include: dev0 from its frames 120 on (the person has left), dev1 from its frames 60 on. Then, with
``scene_from`` (no priming, as ``d2sr detect --scene-from`` runs):

* clean: dev0 frames 0-119 (a person walks through its first frames) and dev1 frames 0-59: frames flagged;
* the outside sets A-I (``bench.outside``'s ``every_other`` on dev0 60-119 and dev1 0-59): precision and recall, mean
  and worst, beside the primed scene's in the same run; with ``--repair``, also the repair as ``d2sr
  recover`` ships it (flagged frames): the corrupted frames' RMSE change against the clean frame over its
  returns, frames made worse, and the share of uncorrupted pixels changed.

Run:  python -m lab.stored_scene_l515 --data ../shared/data [--repair] [--json out.json]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import every_other, open_sets

from d2sr.atomic import write_result
from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.provenance import data_read
from d2sr.runtime.backends import Backend, open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import RunSettings
from d2sr.scene.stored import learn_scene

SCALE = 4000.0
# (view, frames judged, frames the stored scene is learned from): disjoint.
VIEWS = {"dev0": (slice(0, 120), slice(120, None)), "dev1": (slice(0, 60), slice(60, None))}


def _frames(data: Path, view: str) -> list[np.ndarray]:
    files = sorted((data / "l515" / view).glob("*.png"))
    return [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files]


def results(net: Backend, frames: list[np.ndarray], scene: Path | None, repair: str) -> list:
    """Each frame's result, in order: with the stored scene ``scene``, or primed on the frames (None)."""
    loop = SensorLoop(
        net, make_controller("static", 30, 30), settings=RunSettings(repair=repair, scene_from=scene)
    )
    caps = (Capture(Frame(f"{i}", f), SCALE) for i, f in enumerate(frames))
    if scene is None:
        caps = loop.primed(caps)
    return [loop.process(c) for c in caps]


def flags(net: Backend, frames: list[np.ndarray], scene: Path | None) -> np.ndarray:
    return np.array([r.flagged for r in results(net, frames, scene, "none")])


def repair_figures(outs: list, bad: list[np.ndarray], clean: list[np.ndarray]) -> dict[str, float]:
    """Summed over a set's views: (squared error before, after, pixels, frames worse, uncorrupted pixels
    changed, uncorrupted pixels)."""
    se0 = se1 = n = worse = changed = kept = 0.0
    for r, b, c in zip(outs, bad, clean, strict=True):
        ok = c > 0
        untouched = b == c
        changed += float((untouched & (r.depth != b)).sum())
        kept += float(untouched.sum())
        if untouched.all():
            continue
        e0 = float((((b.astype(np.float64) - c) / SCALE)[ok] ** 2).sum())
        e1 = float((((r.depth.astype(np.float64) - c) / SCALE)[ok] ** 2).sum())
        se0, se1, n, worse = se0 + e0, se1 + e1, n + float(ok.sum()), worse + (e1 > e0 + 1e-9)
    return {"se0": se0, "se1": se1, "n": n, "worse": worse, "changed": changed, "kept": kept}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--repair", action="store_true", help="also the repair as recover ships it")
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
        rec = open_backend(RunSettings(backend="onnx")) if args.repair else None
        for which in open_sets():
            out = {}
            for how in ("stored", "primed"):
                tp = fp = pos = 0
                sums: dict[str, float] = {}
                for v, clean in parts.items():
                    bad = every_other(clean, SCALE, which)
                    hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
                    scene = scenes[v] if how == "stored" else None
                    if rec is not None:
                        outs = results(rec, bad, scene, "flagged")
                        f = np.array([r.flagged for r in outs])
                        for k, x in repair_figures(outs, bad, clean).items():
                            sums[k] = sums.get(k, 0.0) + x
                    else:
                        f = flags(net, bad, scene)
                    tp, fp, pos = tp + int((f & hit).sum()), fp + int((f & ~hit).sum()), pos + int(hit.sum())
                out[how] = {"precision": round(tp / max(tp + fp, 1), 3), "recall": round(tp / max(pos, 1), 3)}
                if sums:
                    out[how] |= {
                        "rmse_change": round(float(np.sqrt(sums["se1"] / sums["se0"]) - 1), 4),
                        "frames_worse": int(sums["worse"]),
                        "uncorrupted_changed": round(sums["changed"] / max(sums["kept"], 1), 5),
                    }
            result["outside"][which] = out
    sets = result["outside"].values()
    result["mean_worst"] = {
        how: {
            m: {
                "mean": round(float(np.mean([s[how][m] for s in sets])), 4),
                # the worst: the lowest precision or recall, the least RMSE change
                "worst": (max if m == "rmse_change" else min)(s[how][m] for s in sets),
            }
            for m in ("precision", "recall", "rmse_change")
            if m in next(iter(sets))[how]
        }
        for how in ("stored", "primed")
    }
    read = [f for v in VIEWS for f in sorted((args.data / "l515" / v).glob("*.png"))]
    what = "l515/dev0, l515/dev1 (outside sets A-I on dev0 60-119 and dev1 0-59)"
    print(write_result(result, args.json, data=data_read(what, read, args.data)))


if __name__ == "__main__":
    main()
