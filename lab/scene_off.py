"""Off windows flag frames (issue 42): SceneReference(off_area=None, as shipped / OFF_AREA): a 15 x 15 window
of the shifted windows' pixels most of which read over 2 cm off the scene's median, either way (a rippled or
blotched surface, whose signed mean the shifted windows do not see), fresh, over 0.1% of the known scene.
Every open set's two L515 views (primed as d2sr detect judges a recording, and cold as a live sensor starts)
and its hand-held D435 part (primed); beside them the clean sequences whole. Precision / recall / clean
frames flagged. Development figures only.
Run from the repository root: python -m lab.scene_off [SET ...]"""

import sys
from pathlib import Path

import numpy as np
from d2sr.reference import OFF_AREA

from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set
from lab.scene_gate import cell
from lab.scene_gate import flags as loop_flags

net = open_backend(None, "onnx")
data = Path("../shared/data")
L = outside_set(data)
seqs = clean_sequences(data)
d435 = seqs["d435"][0]
MODES = {"shipped": {}, "off": {"off_area": OFF_AREA}}


def flags(frames, scale, mode, prime=PRIME_FRAMES):
    return loop_flags(net, frames, scale, True, MODES[mode], prime, True)


for n, (fr, s) in seqs.items():
    print(f"clean {n}: primed shipped {int(flags(fr, s, 'shipped').sum())}, off {int(flags(fr, s, 'off').sum())}; "
          f"cold shipped {int(flags(fr, s, 'shipped', 0).sum())}, off {int(flags(fr, s, 'off', 0).sum())} of {len(fr)}",
          flush=True)  # fmt: skip
print("| set | L515 primed, shipped | off | L515 cold, shipped | off | D435 primed, shipped | off |")
print("|---|---|---|---|---|---|---|")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    bd = every_other(d435, 1000.0, s)
    hd = np.array([bool((b != c).any()) for b, c in zip(bd, d435)])
    cells = []
    for prime in (PRIME_FRAMES, 0):
        for mode in MODES:
            cells.append(
                cell(np.concatenate([flags(bad[v : v + 60], 4000.0, mode, prime) for v in (0, 60)]), hit)
            )
    cells += [cell(flags(bd, 1000.0, mode), hd) for mode in MODES]
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
