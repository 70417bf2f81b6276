"""What the scene's upkeep costs a cold start and a steady sensor (issue 44's typical case): CPU a clean frame
through ``d2sr.Pipeline`` (as shipped, flagged frames repaired) on each L515 view, cold (the outside set's
60 frames from a fresh Pipeline, no frame replayed; sessions warmed on another Pipeline first) and steady
(the whole sequence, timed after its first 60 frames), with the statistics refreshed one stripe of 16 per
clean frame (as shipped) or of 32; and with the whole statistics worked out again when the ring reaches 8
and 16 frames (``--milestones``). Medians of 3 alternating passes; the detector's runs in the cold pass.
``--flags``: instead, the candidate (stripes of 32 with the milestones) against the shipped upkeep by the
loop's flags with the scene, on the clean sequences (L515 dev0, dev1, the D435, whole) and on both L515 views
of every development set (each view a cold sequence of 60 frames, every other one corrupted).
Run from the repository root: python -m lab.scene_upkeep_cold [--milestones | --flags]"""

import statistics
import sys
import time
from pathlib import Path

import d2sr.reference as reference

import d2sr
from d2sr.frames import open_frames
from lab.held_out import OUTSIDE_CAMERAS, SEALED, SETS, every_other, outside_set

MILESTONES = (8, 16) if "--milestones" in sys.argv else ()  # --flags sets them per variant
shipped_add = reference.SceneReference.add


def add(self, frame):  # the ring reaching a milestone: every statistic worked out again from it
    before = self.count
    shipped_add(self, frame)
    if (
        self.count != before
        and self.count in MILESTONES
        and self._stats is not None
        and self.count > self.warm
    ):
        self._stats = reference._stats(self._ring[: self.count], self.scale)
        self._labeller = reference.Labeller(self._stats, tol_abs=self.tol[0], tol_rel=self.tol[1])
        self._limits()


reference.SceneReference.add = add
data = Path("../shared/data")
clean = outside_set(data)


def compare_flags():
    import numpy as np

    from d2sr.desync import make_controller
    from d2sr.frames import Frame
    from d2sr.runtime.backends import open_backend
    from d2sr.runtime.loop import Capture, SensorLoop

    net = open_backend(None, "onnx")

    def flags(frames, scale, variant):
        global MILESTONES
        MILESTONES = variant[1]
        options = {"stripes": variant[0]}
        lp = SensorLoop(
            net, make_controller("static", 30, 30), repair="none", scene=True, scene_options=options
        )
        return np.array([lp.process(Capture(Frame(f"{i}", f), scale)).flagged for i, f in enumerate(frames)])

    shipped, cand = (16, ()), (32, (8, 16))
    for n, p, scale in (
        ("dev0", "l515/dev0", 4000.0),
        ("dev1", "l515/dev1", 4000.0),
        ("d435", "d435", 1000.0),
    ):
        f = [x.depth for x in open_frames(data / p)]
        print(f"{n} (clean): flagged {int(flags(f, scale, shipped).sum())} -> {int(flags(f, scale, cand).sum())} "
              f"of {len(f)}")  # fmt: skip
    for w in sorted(set(SETS) - SEALED):
        bad = every_other(clean, 4000.0, w)
        hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
        a = np.concatenate([flags(bad[v : v + 60], 4000.0, shipped) for v in (0, 60)])
        b = np.concatenate([flags(bad[v : v + 60], 4000.0, cand) for v in (0, 60)])
        ra, rb = (a & hit).sum() / hit.sum(), (b & hit).sum() / hit.sum()
        pa, pb = (a & hit).sum() / max(a.sum(), 1), (b & hit).sum() / max(b.sum(), 1)
        print(f"set {w}: recall {ra:.3f} -> {rb:.3f}, precision {pa:.3f} -> {pb:.3f}, flags changed "
              f"{(a != b).sum()}", flush=True)  # fmt: skip


if "--flags" in sys.argv:
    compare_flags()
    sys.exit()
warm = d2sr.Pipeline(4000.0)
for f in clean[:5]:
    warm.process(f)


def timed(frames, stripes, settle=0):
    pipe = d2sr.Pipeline(4000.0)
    pipe.loop.scene_options = {"stripes": stripes}
    runs = [0]
    scores = pipe.loop.backend.scores

    def counted(*a, **k):
        runs[0] += 1
        return scores(*a, **k)

    for f in frames[:settle]:
        pipe.process(f)
    pipe.loop.backend.scores = counted  # shared by every Pipeline of this process: put back below
    try:
        c = time.process_time()
        flagged = sum(bool(pipe.process(f).interfered) for f in frames[settle:])
        cpu = 1000 * (time.process_time() - c) / len(frames[settle:])
    finally:
        vars(pipe.loop.backend).pop("scores", None)
    return cpu, flagged, runs[0]


for view in ("dev0", "dev1"):
    cold = [f for f, cam in zip(clean, OUTSIDE_CAMERAS, strict=True) if cam == view]
    whole = [f.depth for f in open_frames(data / "l515" / view)]
    out = {16: ([], []), 32: ([], [])}
    for _ in range(3):
        for stripes in (16, 32):
            out[stripes][0].append(timed(cold, stripes))
            out[stripes][1].append(timed(whole, stripes, 60))
    for stripes, (c, s) in out.items():
        print(f"{view} stripes {stripes}{' milestones ' + str(MILESTONES) if MILESTONES else ''}: cold "
              f"{statistics.median(x[0] for x in c):.2f} ms ({c[0][1]} flagged, {c[0][2]} detector runs), "
              f"steady {statistics.median(x[0] for x in s):.2f} ms ({s[0][1]} flagged)", flush=True)  # fmt: skip
