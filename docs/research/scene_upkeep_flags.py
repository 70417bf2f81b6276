"""The candidate upkeep of docs/research/scene_upkeep_cold.py (statistics refreshed one stripe of 32 per clean
frame, and worked out whole when the ring reaches 8 and 16 frames) against the shipped one (one stripe of 16):
the loop's flags with the scene on the clean sequences (L515 dev0, dev1, the D435, whole) and on both L515
views of every development set (each view a cold sequence of 60 frames, every other one corrupted).
Run from the repository root: python docs/research/scene_upkeep_flags.py"""
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, "bench")
import d2sr.reference as reference
from d2sr.desync import make_controller
from d2sr.frames import Frame, open_frames
from d2sr.reference import SceneReference
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from held_out import SEALED, SETS, every_other, outside_set
data = Path("../shared/data")
net = open_backend(None, "onnx")
MILESTONES = ()
shipped_add = SceneReference.add
def add(self, frame):
    before = self.count
    shipped_add(self, frame)
    if self.count != before and self.count in MILESTONES and self._stats is not None and self.count > self.warm:
        self._stats = reference._stats(self._ring[: self.count], self.scale)
        self._labeller = reference.Labeller(self._stats, tol_abs=self.tol[0], tol_rel=self.tol[1])
        self._limits()
SceneReference.add = add
def flags(frames, scale, variant):
    global MILESTONES
    MILESTONES = variant[1]
    options = {"stripes": variant[0]}
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True, scene_options=options)
    return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])
whole = {n: ([f.depth for f in open_frames(data / p)], s) for n, p, s in
         (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))}
l515 = outside_set(data)
shipped, cand = (16, ()), (32, (8, 16))
for n, (f, s) in whole.items():
    print(f"{n} (clean): flagged {int(flags(f, s, shipped).sum())} -> {int(flags(f, s, cand).sum())} of {len(f)}")
for w in sorted(set(SETS) - SEALED):
    bad = every_other(l515, 4000.0, w)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, l515)])
    a = np.concatenate([flags(bad[v:v+60], 4000.0, shipped) for v in (0, 60)])
    b = np.concatenate([flags(bad[v:v+60], 4000.0, cand) for v in (0, 60)])
    ra, rb = (a & hit).sum() / hit.sum(), (b & hit).sum() / hit.sum()
    pa, pb = (a & hit).sum() / max(a.sum(), 1), (b & hit).sum() / max(b.sum(), 1)
    print(f"set {w}: recall {ra:.3f} -> {rb:.3f}, precision {pa:.3f} -> {pb:.3f}, flags changed {(a != b).sum()}", flush=True)
