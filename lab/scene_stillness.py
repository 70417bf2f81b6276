"""How still a sensor is, as its scene reference sees it: per sequence, the frames it was ready for, its restarts,
the share of the known scene each frame deviates by (percentiles) and the frames its fresh evidence flags.
Groundwork for a scene switched on by stillness (scene-reference.md). python -m lab.scene_stillness"""

from pathlib import Path

import numpy as np
from d2sr.reference import SceneReference

from d2sr.frames import open_frames

data = Path("../shared/data")
for n, p, s in (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0)):
    fr = [f.depth for f in open_frames(data / p)]
    ref = SceneReference(s)
    shares, ev_flags, resets = [], [], 0
    for f in fr:
        was = ref.ready
        ev = ref.evidence(f)
        if was and not ev.ready:
            resets += 1
        if ev.ready:
            shares.append(ev.share)
        fl = ev.evident
        ev_flags.append(fl)
        if not fl:
            ref.add(f)
    sh = np.array(shares)
    print(
        n,
        "ready frames",
        len(sh),
        "resets",
        resets,
        "share pct 50/90/99:",
        np.round(np.percentile(sh, [50, 90, 99]), 4) if len(sh) else None,
        "evident",
        int(np.sum(ev_flags)),
    )
