"""Benchmark (issue 42): the detector judged against the sensor's own scene (``d2sr.reference``).

Each sequence runs in order through ``SensorLoop`` with the shipped detector, without and with ``scene`` (a
flag on a frame in which nothing deviates from the scene is dropped; a frame whose fresh evidence, deviations
that nothing moving explains, reaches ``EVIDENT`` is flagged), the scene cold (as a live sensor starts) and
primed on the sequence's first ``PRIME_FRAMES`` frames (as ``d2sr detect`` judges a recording,
``SensorLoop.primed``). Beside them, what all the evidence would flag, moved objects included (not shipped:
it flags the walking person of dev0). Over the outside sets, each rule's mean and worst.
Sequences:

* clean: L515 dev0 (a person walks through its first frames) and dev1, whole; the hand-held D435 (a moving
  sensor: the reference keeps starting again);
* outside sets A-F of ``bench.outside`` (real L515 frames, every other one corrupted), each view a sequence of
  60 frames starting cold (no scene known).

The reference's cost per frame (evidence and update, median) is timed on the still and the moving sensor.

Run:  python -m lab.scene_reference --json docs/results/scene_reference.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import clean_sequences, every_other, open_sets, outside_set, set_data

from d2sr.atomic import write_result
from d2sr.contract.catalog import DETECTOR
from d2sr.desync import make_controller
from d2sr.errors import D2SRError
from d2sr.frames import Frame
from d2sr.runtime.backends import Backend, open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import PRIME_FRAMES, RunSettings
from d2sr.scene import SceneReference, SceneSettings

EVIDENT, QUIET = SceneSettings().evident, SceneSettings().quiet


def run(net: Backend, frames: list[np.ndarray], scale: float) -> dict[str, np.ndarray]:
    """Per frame: flagged by the detector alone, with the scene, by evidence alone; the reference's cost."""

    def loop(scene: bool) -> SensorLoop:
        return SensorLoop(
            net, make_controller("static", 30, 30), settings=RunSettings(repair="none", scene=scene)
        )

    plain, scene, primed = loop(False), loop(True), loop(True)
    ahead = primed.primed(Capture(Frame(f"{i}", f), scale) for i, f in enumerate(frames))
    ref = SceneReference(scale)  # fed as the scene loop's own is, to read its evidence
    out: dict[str, list] = {"detector": [], "scene": [], "primed": [], "evidence": [], "ms": []}
    for i, (f, cap) in enumerate(zip(frames, ahead, strict=True)):
        out["detector"].append(plain.process(Capture(Frame(f"{i}", f), scale)).flagged)
        out["primed"].append(primed.process(cap).flagged)
        flagged = scene.process(Capture(Frame(f"{i}", f), scale)).flagged
        t = time.perf_counter()
        ev = ref.evidence(f)
        if not flagged:
            ref.add(f)
        out["ms"].append(1000 * (time.perf_counter() - t))
        out["scene"].append(flagged)
        out["evidence"].append(ev.ready and ev.dense >= EVIDENT)
    return {k: np.array(v) for k, v in out.items()}


# Per kind of flags: its name in the result.
RULES = {
    "detector": "detector",
    "scene": "detector + scene, cold (a live sensor)",
    "primed": "detector + scene, primed (d2sr detect on a recording)",
    "evidence": "detector or all evidence (not shipped)",
}


def rates(flags: dict[str, np.ndarray], hit: np.ndarray) -> dict:
    out: dict = {"frames": len(hit), "interfered": int(hit.sum())}
    rules = {name: flags[k] for k, name in RULES.items() if k != "evidence"}
    rules[RULES["evidence"]] = flags["detector"] | flags["evidence"]
    for name, f in rules.items():
        tp = int((f & hit).sum())
        out[name] = {
            "precision": round(tp / max(int(f.sum()), 1), 3),
            "recall": round(tp / max(int(hit.sum()), 1), 3),
            "clean flagged": f"{int((f & ~hit).sum())} of {int((~hit).sum())}",
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    try:
        net = open_backend(RunSettings(backend="onnx"), recovery=False)
        seqs = clean_sequences(args.data)
    except D2SRError as exc:
        ap.error(str(exc))
    result: dict = {"clean": {}, "outside": {}, "ms_per_frame": {}}
    for name, (frames, scale) in seqs.items():
        flags = run(net, frames, scale)
        result["clean"][name] = {RULES[k]: f"{int(flags[k].sum())} of {len(frames)}" for k in RULES}
        result["ms_per_frame"]["moving (D435)" if name == "d435" else f"still (L515 {name})"] = round(
            float(np.median(flags["ms"])), 2
        )
    clean = outside_set(args.data)
    for which in open_sets():
        bad = every_other(clean, 4000.0, which)
        hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
        parts = [run(net, bad[a : a + 60], 4000.0) for a in (0, 60)]  # each view cold
        flags = {k: np.concatenate([p[k] for p in parts]) for k in RULES}
        result["outside"][which] = rates(flags, hit) | {"status": set_data(which)["status"]}
    sets = result["outside"].values()
    result["outside_mean_worst"] = {
        name: {
            m: {
                "mean": round(float(np.mean([s[name][m] for s in sets])), 3),
                "worst": min(s[name][m] for s in sets),
            }
            for m in ("precision", "recall")
        }
        for name in RULES.values()
    }
    result["settings"] = {"quiet": QUIET, "evident": EVIDENT, "prime_frames": PRIME_FRAMES}
    print(
        write_result(result, args.json, models=[DETECTOR], data="real L515 dev0/dev1, D435; outside sets A-I")
    )


if __name__ == "__main__":
    main()
