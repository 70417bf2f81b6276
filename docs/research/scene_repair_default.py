"""The scene's repair on by default where frames are judged (issue 42): ``d2sr.Pipeline`` as shipped (scene
on, flagged frames repaired) with ``scene_repair`` off and on, on both views of every development set (each
view cold, the 120 frames seeded as one, as ``bench/scene_reference.py`` seeds them) and on the clean
sequences (L515 dev0, dev1, the D435, whole). Per set: RMSE change over the corrupted frames, frames made
worse, RMSE change per view over all its frames, pixels moved > 2 cm put back within 1 cm, clean pixels
changed (of the corrupted frames' untouched pixels and of the clean frames); per clean sequence, the valid
pixels moved by more than 5 cm. Development figures only.
Run from the repository root: python docs/research/scene_repair_default.py [SET ...]"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "bench")
from d2sr.runtime.pipeline import Pipeline
from held_out import SETS, SEALED, clean_sequences, every_other, outside_set

data = Path("../shared/data")
l515 = outside_set(data)
sets = sys.argv[1:] or sorted(set(SETS) - SEALED)


def pipeline(scale, repair):
    p = Pipeline(scale)
    p.loop.scene_repair = repair
    return p


def on_set(w, repair):
    bad = every_other(l515, 4000.0, w)
    e_in = e_out = 0.0
    worse = hits = moved = back = changed = pixels = 0
    view = [[0.0, 0.0], [0.0, 0.0]]
    for v in (0, 1):
        p = pipeline(4000.0, repair)
        for i in range(60 * v, 60 * v + 60):
            b, c = bad[i], l515[i]
            out = p.process(b).depth.astype(np.float64)
            ok = c > 0
            a = float((((b - c.astype(np.float64)) / 4000)[ok] ** 2).sum())
            z = float((((out - c) / 4000)[ok] ** 2).sum())
            view[v][0] += a
            view[v][1] += z
            true = b != c
            if true.any():
                hits += 1
                e_in, e_out, worse = e_in + a, e_out + z, worse + (z > a)
                far = ok & (b > 0) & (np.abs(b.astype(np.float64) - c) > 0.02 * 4000)
                moved += int(far.sum())
                back += int((far & (np.abs(out - c) <= 0.01 * 4000)).sum())
            changed += int(((out != b) & ~true).sum())
            pixels += int((~true).sum())
    views = " / ".join(f"{100 * (np.sqrt(z / a) - 1):+.1f}%" for a, z in view)
    return (f"RMSE {100 * (np.sqrt(e_out / e_in) - 1):+.1f}%, worse {worse} of {hits}, views {views}, "
            f"put back {back / max(moved, 1):.1%}, clean px changed {changed / pixels:.3%}")


for w in sets:
    for repair in (False, True):
        print(f"set {w} scene_repair={repair}: {on_set(w, repair)}", flush=True)
for name, (frames, scale) in clean_sequences(data).items():
    for repair in (False, True):
        p = pipeline(scale, repair)
        moved = valid = 0
        for f in frames:
            out = p.process(f).depth.astype(np.float64)
            ok = f > 0
            moved += int((ok & (np.abs(out - f) > 0.05 * scale)).sum())
            valid += int(ok.sum())
        print(f"{name} clean scene_repair={repair}: valid pixels moved > 5 cm {moved / valid:.4%}", flush=True)
