"""Full frame rate from a duty-cycled sensor: the frames its laser skips, synthesized from the last real one
and where the camera went (the caller's odometry, or the colour stream). Torch-free.

```python
f = Filler(intrinsics)      # the depth's (aligned to colour) d2sr.frames.Intrinsics; None: guessed
f.real(metres, colour)      # every frame the laser made
s = f.synthesize(colour)    # every frame it skipped: s.depth, s.confidence, s.method
```
"""

from d2sr.synth.fill import METHODS, Filler, Synthesized
from d2sr.synth.recording import FillSettings, FillSummary, fill_recording
from d2sr.synth.warp import Pose, warp_depth

__all__ = [
    "METHODS",
    "FillSettings",
    "FillSummary",
    "Filler",
    "Pose",
    "Synthesized",
    "fill_recording",
    "warp_depth",
]
