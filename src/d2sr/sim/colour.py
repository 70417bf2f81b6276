"""What a colour camera beside the depth camera sees (grey, 8-bit): each surface's own albedo, a texture
fixed to the world (so it stays put as the camera moves and features can be matched frame to frame), and
light falling off with the angle of incidence. Aligned to the depth pixel for pixel, as a depth stream
aligned to colour is. Colour keeps streaming while the laser is off, so synthesis of skipped frames
(``d2sr.synth``) can be measured against ground truth here."""

from __future__ import annotations

import numpy as np

from d2sr.sim.rooms import Render, Renderer

__all__ = ["grey"]

#: The texture: plane waves through the world at random directions and wavelengths (4 to 80 cm; fixed
#: seed, so every room shares one material), the longer ones stronger. Their sum looks like grain and
#: blotches, and costs a few products a pixel where hashed lattice noise cost ten times as much.
_W = np.random.default_rng(0xC0102)
_DIRS = _W.normal(size=(20, 3))
_LENGTHS = np.exp(_W.uniform(np.log(0.04), np.log(0.8), 20))
WAVES = (_DIRS / np.linalg.norm(_DIRS, axis=1, keepdims=True) * (2 * np.pi / _LENGTHS)[:, None]).astype(
    np.float32
)
PHASES = _W.uniform(0, 2 * np.pi, 20).astype(np.float32)
AMPLITUDES = (np.sqrt(_LENGTHS) / np.sqrt((_LENGTHS).sum()) / 2.5).astype(np.float32)
EMPTY = 20  # grey where nothing is hit


def grey(
    cam: Renderer, render: Render, noise: float = 0.0, rng: np.random.Generator | None = None
) -> np.ndarray:
    """The colour camera's grey image of ``render`` (what ``cam`` rendered, same size), with Gaussian sensor
    noise of ``noise`` grey levels when ``rng`` is given."""
    hit = render.depth > 0
    points = cam.points(render.depth)
    texture = 0.5 + np.sin(points @ WAVES.T + PHASES) @ AMPLITUDES
    # a surface's visible albedo from its infrared reflectivity, which is unique to it: a colour edge
    # wherever one surface meets another, as in a real room, but no tie between the two
    albedo = 0.15 + 0.7 * np.modf(render.refl * 9973.0)[0]
    light = 0.3 + 0.7 * np.clip(render.cos, 0, 1)
    out = 255 * np.clip(albedo * light * (0.45 + 0.9 * texture), 0, 1)
    out = np.where(hit, out, EMPTY).astype(np.float32)
    if rng is not None and noise > 0:
        out += rng.normal(0, noise, out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)
