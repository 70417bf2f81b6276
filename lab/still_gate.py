"""The stillness gate on development sequences (scene-reference.md): per setting of ``SceneReference``'s
``still_share`` (None: no gate, ``--scene`` before the gate), ``STILL_Q`` and ``STILL_MIN``, the frames ``SensorLoop``
with ``scene`` flags on the clean L515 dev0 and dev1 and the hand-held D435, and detection on outside sets
A-I (each view a cold sequence of 60 frames). Beside them, the detector alone.
python -m lab.still_gate"""

from functools import partial
from pathlib import Path

import d2sr.reference as reference
import numpy as np

import d2sr.runtime.loop as loop_mod
from d2sr.desync import make_controller
from d2sr.frames import Frame, open_frames
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from lab.held_out import every_other, open_sets, outside_set

data = Path("../shared/data")
net = open_backend(None, "onnx")


def flags(frames, scale, scene):
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=scene)
    return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])


clean = {
    n: ([f.depth for f in open_frames(data / p)], s)
    for n, p, s in (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))
}
base = outside_set(data)
sets = {}
for w in open_sets():
    bad = every_other(base, 4000.0, w)
    sets[w] = (bad, np.array([bool((b != c).any()) for b, c in zip(bad, base, strict=True)]))
# The shipped setting (reference.STILL_*), the scene ungated (share None) and the settings tried beside them.
settings = [
    ("detector", None, 0.0, 0),
    ("shipped", reference.STILL_SHARE, reference.STILL_Q, reference.STILL_MIN),
]
settings += [
    (f"share {s} q {q} min {m}", s, q, m)
    for s, q, m in (
        (None, 0.25, 1),
        (0.05, 0.5, 4),
        (0.05, 0.5, 2),
        (0.1, 0.5, 4),
        (0.02, 0.5, 4),
        (0.05, 0.25, 4),
        (0.1, 0.25, 4),
        (0.05, 0.0, 4),
        (0.03, 0.0, 4),
        (0.1, 0.0, 1),
        (0.05, 0.0, 1),
        (0.1, 0.0, 2),
        (0.05, 0.25, 1),
    )
]
for name, share, q, least in settings:
    scene = name != "detector"
    if scene:
        loop_mod.SceneReference = partial(reference.SceneReference, still_share=share)
        reference.STILL_Q, reference.STILL_MIN = q, least
    row = [f"{name:>20}"]
    for n, (fr, s) in clean.items():
        row.append(f"{n} {int(flags(fr, s, scene).sum())}/{len(fr)}")
    worst, rec = 1.0, []
    for w, (bad, hit) in sets.items():
        f = np.concatenate([flags(bad[a : a + 60], 4000.0, scene) for a in (0, 60)])
        r = (f & hit).sum() / hit.sum()
        p = (f & hit).sum() / max(f.sum(), 1)
        rec.append(f"{w}:{r:.2f}/{p:.2f}")
    print(" ".join(row), "| R/P", " ".join(rec), flush=True)
