"""Shifted windows flagging frames again (issue 42): the loop's flags with the scene as shipped
(``shift_area=None``) against candidate ``SceneReference(shift_area=...)`` values, on every development
sequence (L515 dev0, dev1 and the D435 whole; both views of sets A-I, K and L, seeded as
``lab/scene_reference.py`` seeds them; the D435 part of K and L).
Precision and recall per set, clean frames flagged per sequence; then the highest share of the scene that
fresh shifted windows reach on a clean frame where the scene is usable (the clean sequences, and the clean
frames of every set). Development figures only. Far-off flags (added after it) are off, as when it was run.
Run from the repository root: python -m lab.scene_shift_flags [AREA ...]"""

import sys
from pathlib import Path

import numpy as np

from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from lab.held_out import clean_sequences, every_other, open_sets, outside_set

data = Path("../shared/data")
net = open_backend(None, "onnx")
areas = [None, *(float(a) for a in sys.argv[1:])] if len(sys.argv) > 1 else [None, 0.02]


def flags(frames, scale, area):
    lp = SensorLoop(
        net,
        make_controller("static", 30, 30),
        repair="none",
        scene=True,
        scene_options={"shift_area": area, "far_area": None},
    )
    return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])


whole = clean_sequences(data)
l515 = outside_set(data)
print("sequence".ljust(12), *(f"area {a}".rjust(22) for a in areas))
for name, (frames, scale) in whole.items():
    print(
        f"{name} clean".ljust(12),
        *(f"{int(flags(frames, scale, a).sum())} of {len(frames)}".rjust(22) for a in areas),
    )
worst = {a: 1.0 for a in areas}
for w in [*open_sets(), "k", "l"]:
    bad = every_other(l515, 4000.0, w)  # seeded as one sequence, as lab/scene_reference.py does
    changed = [bool((b != c).any()) for b, c in zip(bad, l515, strict=True)]  # a hit: the frame changed
    parts = [(bad[a : a + 60], 4000.0, changed[a : a + 60]) for a in (0, 60)]  # each view cold
    rows = {"l515": parts}
    if w in ("k", "l"):
        d435 = whole["d435"][0]
        bad = every_other(d435, 1000.0, w)
        rows["d435"] = [(bad, 1000.0, [bool((b != c).any()) for b, c in zip(bad, d435, strict=True)])]
    for part, seqs in rows.items():
        cells = []
        for a in areas:
            tp = fp = pos = 0
            for frames, scale, changed in seqs:
                f = flags(frames, scale, a)
                hit = np.array(changed)
                tp += int((f & hit).sum())
                fp += int((f & ~hit).sum())
                pos += int(hit.sum())
            p, r = tp / max(tp + fp, 1), tp / pos
            if part == "l515":
                worst[a] = min(worst[a], r)
            cells.append(f"P {p:.3f} R {r:.3f}".rjust(22))
        print(f"set {w} {part}".ljust(12), *cells)
print("worst L515 recall".ljust(12), *(f"{worst[a]:.3f}".rjust(22) for a in areas))


def peaks(frames, scale, hit):
    """The highest ``Evidence.fresh_shifted`` on the frames not in ``hit`` where the scene was usable."""
    lp = SensorLoop(
        net,
        make_controller("static", 30, 30),
        repair="none",
        scene=True,
        scene_options={"shift_area": 1.0, "far_area": None},
    )
    seen = []
    judge = lp._scene_evidence

    def keep(*args):
        units, ev = judge(*args)
        seen.append(ev)
        return units, ev

    lp._scene_evidence = keep
    top = 0.0
    for i, f in enumerate(frames):
        seen.clear()
        lp.process(Capture(Frame(f"{i}", f), scale))
        if seen and seen[0].usable and not hit[i]:
            top = max(top, seen[0].fresh_shifted)
    return top


print("fresh shifted windows on clean frames, highest share:")
for name, (frames, scale) in whole.items():
    print(f"  {name} clean: {peaks(frames, scale, [False] * len(frames)):.4f}")
top = 0.0
for w in [*open_sets(), "k", "l"]:
    bad = every_other(l515, 4000.0, w)
    hit = [bool((b != c).any()) for b, c in zip(bad, l515, strict=True)]
    top = max(top, *(peaks(bad[a : a + 60], 4000.0, hit[a : a + 60]) for a in (0, 60)))
print(f"  clean frames of sets A-L: {top:.4f}")
