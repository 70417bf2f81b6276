"""The scene reference's outputs hashed over 1071 frames (L515 dev0, dev1, the D435, sets A, D, G, H in
order): every evidence, statistic and repair array. Run it at two commits from the repository root; the same
hash means the same outputs bit for bit. The reference runs ungated (``still_share=None``, where the commit has
the stillness gate), as every commit before the gate did. From the repository root, with the d2sr to hash
first on the path: PYTHONPATH=OTHER/src python -m lab.scene_identity"""

import hashlib
import time
from pathlib import Path

import numpy as np

from d2sr.frames import open_frames
from lab.held_out import every_other, outside_set

try:  # the scene's home since 6d6f076
    from d2sr.scene import SceneReference, SceneSettings

    def ungated(scale: float) -> SceneReference:
        return SceneReference(scale, SceneSettings(still_share=None))
except ImportError:  # before it
    from d2sr.reference import SceneReference  # type: ignore[no-redef]

    def ungated(scale: float) -> SceneReference:
        try:
            return SceneReference(scale, still_share=None)
        except TypeError:  # before the stillness gate (2330224)
            return SceneReference(scale)


data = Path("../shared/data")
seqs = {
    n: ([f.depth for f in open_frames(data / p)], s)
    for n, p, s in (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))
}
clean = outside_set(data)
for which in ("a", "d", "g", "h"):
    bad = every_other(clean, 4000.0, which)
    seqs[which] = (bad, 4000.0)
h = hashlib.sha256()
t = 0.0
for name, (frames, scale) in seqs.items():
    ref = ungated(scale)
    for f in frames:
        c = time.process_time()
        ev = ref.evidence(f)
        flagged = ev.ready and ev.fresh_dense >= 0.003  # EVIDENT; Evidence.evident is newer than f309c3e
        if not flagged:
            ref.add(f)
        t += time.process_time() - c
        for a in (ev.mask, ev.fresh, ev.metres):
            h.update(np.ascontiguousarray(a).tobytes())
        h.update(repr((ev.share, ev.dense, ev.fresh_dense, ev.ready)).encode())
        if ref._stats is not None:
            for k in ("rate", "nz_median", "lo", "hi"):
                h.update(getattr(ref._stats, k).tobytes())
        rep = ref.repair(ev)
        for a in rep:
            h.update(np.ascontiguousarray(a).tobytes())
n = sum(len(f) for f, _ in seqs.values())
print(h.hexdigest()[:16], "ms/frame", round(1000 * t / n, 2), n)
