"""Off windows against a surface that flutters all the time (a curtain in a draught), an observation (issue 42):
a patch of steady returns (rows 280 on, columns 40 on, 40 or 80 px square) of every L515 dev1 frame reads off
by fresh smooth noise each frame (Gaussian noise blurred over 4 px, clipped to +-1 to 5 cm). The loop's flags
over the clean sequence, off windows off and on, cold and primed.
Run from the repository root: python -m lab.scene_off_flutter"""

from pathlib import Path

import cv2
import numpy as np
from d2sr.reference import OFF_AREA

from d2sr.frames import open_frames
from d2sr.runtime.backends import open_backend
from lab.scene_gate import flags as loop_flags

net = open_backend(None, "onnx")
frames = [f.depth for f in open_frames(Path("../shared/data/l515/dev1"))]
rng = np.random.default_rng(0)
for amp in (0.01, 0.02, 0.03, 0.05):
    for size in (40, 80):
        out = []
        for f in frames:
            g = f.astype(np.float64) / 4000
            noise = cv2.GaussianBlur(rng.normal(0, 1, g.shape), (0, 0), 4)
            noise *= amp / max(np.abs(noise).max(), 1e-9) * 2.5
            patch = np.zeros(g.shape, bool)
            patch[280 : 280 + size, 40 : 40 + size] = True
            g = np.where(patch & (g > 0), g + np.clip(noise, -amp, amp), g)
            out.append(np.clip(np.rint(g * 4000), 0, 65535).astype(np.uint16))
        res = {}
        for area in (None, OFF_AREA):
            for prime in (0, 32):
                res[(area, prime)] = int(
                    loop_flags(net, out, 4000.0, True, {"off_area": area}, prime, True).sum()
                )
        print(
            f"amp {amp} patch {size}px: flagged of {len(out)}: "
            + ", ".join(f"off={a} prime={p}: {v}" for (a, p), v in res.items()),
            flush=True,
        )
