"""The scene resting while the sensor keeps moving (decisions.md, 2026-11-27): the loop's flags with the scene,
``SceneReference(rest=0)`` against the shipped ``rest``, on every development sequence (L515 dev0, dev1 and
the D435 whole; both parts of sets K and L; both views of sets A-I), and the CPU a frame through
``Pipeline(repair="none")`` on the D435 and the still L515s, alternating, median of 3 passes.
Run from the repository root: python -m lab.scene_rest"""

import statistics
import time
from functools import partial
from pathlib import Path

import numpy as np
from d2sr.reference import REST, SceneReference

import d2sr.runtime.loop as loop_module
from d2sr.desync import make_controller
from d2sr.frames import Frame, open_frames
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.pipeline import Pipeline
from lab.held_out import every_other, open_sets, outside_set

data = Path("../shared/data")
net = open_backend(None, "onnx")


def use(rest):
    loop_module.SceneReference = partial(SceneReference, rest=rest)


def flags(frames, scale, rest):
    use(rest)
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True)
    return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])


whole = {
    n: ([f.depth for f in open_frames(data / p)], s)
    for n, p, s in (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))
}
seqs = {f"{n} (clean)": v for n, v in whole.items()}
l515 = outside_set(data)
for w in [*open_sets(), "k", "l"]:
    for a in (0, 60):
        seqs[f"set {w} view {a // 60}"] = (every_other(l515[a : a + 60], 4000.0, w), 4000.0)
    if w in ("k", "l"):
        seqs[f"set {w} d435"] = (every_other(whole["d435"][0], 1000.0, w), 1000.0)
changed = total = 0
for name, (frames, scale) in seqs.items():
    a, b = flags(frames, scale, 0), flags(frames, scale, REST)
    changed += int((a != b).sum())
    total += len(a)
    if "clean" in name or (a != b).any():
        print(f"{name}: flagged {int(a.sum())} -> {int(b.sum())} of {len(a)}, changed {int((a != b).sum())}")
print("flags changed", changed, "of", total)
for name, (frames, scale) in whole.items():
    ms = {0: [], REST: []}
    for _ in range(3):
        for rest in (0, REST):
            use(rest)
            p = Pipeline(scale, repair="none")
            t = time.process_time()
            for f in frames:
                p.process(f)
            ms[rest].append(1000 * (time.process_time() - t) / len(frames))
    print(name, "CPU ms a frame, rest 0 /", REST, ":", *(round(statistics.median(v), 2) for v in ms.values()))
use(REST)
