"""The loop's scene flags and the reference's cost, stripes=8 against 16, on every development sequence
(decisions.md, 2026-11-27). Run from the repository root: python -m lab.scene_stripes"""

import statistics
import time
from pathlib import Path

import numpy as np

import d2sr.runtime.loop as loopmod
from d2sr.desync import make_controller
from d2sr.frames import Frame, open_frames
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from lab.held_out import every_other, open_sets, outside_set

net = open_backend(None, "onnx")
data = Path("../shared/data")
orig = loopmod.SceneReference


def flags(frames, scale, stripes):
    loopmod.SceneReference = lambda s: orig(s, stripes=stripes)
    loop = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True)
    return np.array([loop.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])


def cost(frames, scale, stripes):
    ref = orig(scale, stripes=stripes)
    ms = []
    for f in frames:
        t = time.perf_counter()
        ev = ref.evidence(f)
        if not ev.evident:
            ref.add(f)
        ms.append(1000 * (time.perf_counter() - t))
    return statistics.median(ms)


seqs = {
    n: ([f.depth for f in open_frames(data / p)], s, None)
    for n, p, s in (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))
}
clean = outside_set(data)
for which in open_sets():
    bad = every_other(clean, 4000.0, which)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
    seqs[f"set {which}"] = (bad, 4000.0, hit)
changed = total = 0
for name, (frames, scale, hit) in seqs.items():
    if hit is None:
        a, b = flags(frames, scale, 8), flags(frames, scale, 16)
        print(f"{name}: clean flagged {int(a.sum())} -> {int(b.sum())} of {len(frames)}")
    else:
        parts = [[flags(frames[s : s + 60], scale, st) for s in (0, 60)] for st in (8, 16)]
        a, b = (np.concatenate(p) for p in parts)
        r = lambda f: (
            round(float((f & hit).sum() / hit.sum()), 3),
            round(float((f & hit).sum() / max(f.sum(), 1)), 3),
        )
        print(f"{name}: recall, precision {r(a)} -> {r(b)}")
    changed += int((a != b).sum())
    total += len(a)
print("flags changed", changed, "of", total)
for view in ("dev0", "dev1"):
    frames = seqs[view][0]
    c8, c16 = [], []
    for _ in range(3):
        c8.append(cost(frames, 4000.0, 8))
        c16.append(cost(frames, 4000.0, 16))
    print(
        view, "ms a frame, stripes 8 / 16:", round(statistics.median(c8), 2), round(statistics.median(c16), 2)
    )
