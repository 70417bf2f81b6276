"""A primed recording's first frames are judged against a scene whose ring may hold their own copy (issue 42),
an observation: ``SensorLoop.prime`` judges frames 32..2 backwards and the scene keeps those it takes as clean,
so when the loop then judges frames 1-16 forwards, a frame may be in the ring it is judged against. The
candidate takes the frame's own copy out of the ring first (the statistics worked out again over the rest).
Both L515 views of every open set, primed as d2sr detect judges a recording, and the clean sequences whole:
precision / recall / clean frames flagged, as shipped and with the copy taken out. Development figures only.
Run from the repository root: python -m lab.scene_prime_self [SET ...]"""

import sys
from pathlib import Path

import d2sr.reference as reference
import numpy as np
from d2sr.labels import stack_stats

from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES, SensorLoop
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set
from lab.scene_gate import cell
from lab.scene_gate import flags as loop_flags

TAKE_OUT = [False]
tag = [None]
shipped_add, shipped_reset, shipped_decide = (reference.SceneReference.add, reference.SceneReference.reset,
                                              SensorLoop.decide)  # fmt: skip


def add(self, frame):  # remember which frame each ring slot holds
    slot, skip = self._next, self._skip
    shipped_add(self, frame)
    if not skip:
        self._tags[slot] = tag[0]


def reset(self):
    shipped_reset(self)
    self._tags = {}


def take_out(ref, name):
    """Take frame ``name``'s copy out of the ring and work the statistics out again over the rest."""
    if ref._ring is None or ref._stats is None:
        return
    order = (
        [(ref._next + k) % ref.size for k in range(ref.size)]
        if ref.count == ref.size
        else list(range(ref.count))
    )
    keep = [j for j in order if ref._tags.get(j) != name]
    if len(keep) == len(order) or len(keep) < ref.warm:
        return
    ref._ring[: len(keep)] = ref._ring[keep].copy()
    ref._tags = {i: ref._tags.get(j) for i, j in enumerate(keep)}
    ref.count, ref._next = len(keep), len(keep) % ref.size
    for key, v in reference._metres(stack_stats(ref._ring[: ref.count], reference.READ), ref.scale).items():
        getattr(ref._stats, key)[:] = v
    ref._limits()


def decide(self, cap):
    tag[0] = cap.frame.name
    if TAKE_OUT[0] and cap.counted and self._reference is not None:
        take_out(self._reference, cap.frame.name)
    return shipped_decide(self, cap)


reference.SceneReference.add, reference.SceneReference.reset, SensorLoop.decide = add, reset, decide
net = open_backend(None, "onnx")
data = Path("../shared/data")
L = outside_set(data)


def flags(frames, scale, out):
    TAKE_OUT[0] = out
    return loop_flags(net, frames, scale, True, {}, PRIME_FRAMES, True)


print("clean sequences flagged (as shipped, copy taken out):",
      {n: (int(flags(fr, s, False).sum()), int(flags(fr, s, True).sum())) for n, (fr, s) in clean_sequences(data).items()})  # fmt: skip
print("| set | as shipped | own copy taken out |")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    cells = []
    for out in (False, True):
        f = np.concatenate([flags(bad[:60], 4000.0, out), flags(bad[60:], 4000.0, out)])
        cells.append(cell(f, hit))
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
