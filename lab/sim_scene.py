"""Why the scene seldom weighs in on simulated rooms (``d2sr run sim`` and ``make demo`` leave it off), an
observation: one still simulated L515 (``d2sr simulate``, 4 s at 30 frames a second, seed 3), its clean
frames, with no people in the room and with two. The share of the known scene each frame deviates by, against
a SceneReference that never restarts (``moved=1.0``, ungated), over the first frames; then the loop as shipped
(``SensorLoop(scene=True)``) and with ``moved=1.0``: frames flagged and frames whose scene weighed the
verdict. Beside them, the real L515 sequences (dev0, dev1) against the same never-restarting scene.
Run from the repository root: python -m lab.sim_scene"""

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from d2sr.desync import make_controller
from d2sr.frames import Frame, open_frames
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.runtime.settings import RunSettings
from d2sr.scene import SceneReference, SceneSettings

net = open_backend(RunSettings(backend="onnx"), recovery=False)


def shares(frames):
    """Each frame's deviating share against a scene that never restarts (None before it is warm)."""
    ref = SceneReference(4000.0, SceneSettings(still_share=None, rest=0, moved=1.0))
    out = []
    for f in frames:
        ref.evidence(f)
        out.append(ref._judged)
        ref.add(f)
    return [s for s in out if s is not None]


for view in ("dev0", "dev1"):
    judged = shares([f.depth for f in open_frames(Path("../shared/data/l515") / view)])
    print(
        f"L515 {view}: frames 4-19: {[round(s, 3) for s in judged[:16]]}; median after: {np.median(judged[16:]):.3f}"
    )
with tempfile.TemporaryDirectory() as tmp:
    for people in (0, 2):
        out = Path(tmp) / f"people{people}"
        subprocess.run([sys.executable, "-m", "d2sr", "simulate", "--out", str(out), "--sensors", "1",
                        "--seconds", "4", "--active-frames", "30", "--people", str(people), "--seed", "3"],
                       check=True, capture_output=True)  # fmt: skip
        frames = [f.depth for f in open_frames(out / "sensor0" / "clean")]
        judged = shares(frames)
        print(
            f"{people} people: deviating share, frames 4-19: {[round(s, 2) for s in judged[:16]]}; "
            f"median after: {np.median(judged[16:]):.3f}"
        )
        for opts in ({}, {"moved": 1.0}):
            run = RunSettings(repair="none", scene=True, scene_settings=SceneSettings(**opts))
            lp = SensorLoop(net, make_controller("static", 30, 30), settings=run)
            res = [lp.process(Capture(Frame(str(i), f), 4000.0)) for i, f in enumerate(frames)]
            print(
                f"  loop {opts or 'as shipped'}: flagged {sum(r.flagged for r in res)} of {len(res)}, "
                f"the scene weighed {sum(bool(r.scene) for r in res)}"
            )
