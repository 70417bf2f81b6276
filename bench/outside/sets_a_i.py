"""Sets A-I: the interference the README's outside rows are measured on (``bench.outside``)."""

from __future__ import annotations

import cv2
import numpy as np
from bench.outside.draw import _ellipse, _start, _written


def outside_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Corrupt a uint16 frame with one of the two outside models (chosen by the seed)."""
    rng, h, w, d = _start(frame, scale, seed, "a")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if rng.random() < 0.5:  # phase-wrapping rings
        cx, cy = rng.uniform(-0.5, 1.5) * w, rng.uniform(-0.5, 1.5) * h
        r = np.hypot(x - cx, (y - cy) * rng.uniform(0.6, 1.6))
        period, duty = rng.uniform(20, 90), rng.uniform(0.1, 0.45)
        where = ((r / period + rng.uniform(0, 1)) % 1) < duty
        ambiguity = rng.uniform(0.8, 2.5)
        new = np.mod(d + rng.uniform(0, ambiguity), ambiguity) + 0.2
    else:  # sawtooth stripes
        ang = rng.uniform(0, np.pi)
        s = x * np.cos(ang) + y * np.sin(ang)
        period = rng.uniform(30, 120)
        ramp = (s / period) % 1
        where = ramp < rng.uniform(0.15, 0.5)
        new = d * (0.3 + 0.6 * ramp)
    region = np.ones((h, w), bool)
    if rng.random() < 0.5:  # only where the views overlap
        region = x * np.cos(rng.uniform(0, 6.3)) + y * np.sin(rng.uniform(0, 6.3)) > rng.uniform(0, 0.6) * w
    where &= region & (rng.random((h, w)) < rng.uniform(0.5, 1.0)) & (d > 0)
    out = np.where(where, np.clip(np.rint(new * scale), 1, 65535), frame)
    return out.astype(np.uint16)


def crosstalk_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set B (written after a threshold was read off set A, to check it on a set nobody had looked at):
    corrupt a uint16 frame with one of two more outside models, chosen by the seed. Neither is in
    ``d2sr.sim``, and neither is ``outside_interference``'s:

    * another scanner's spot tracing a Lissajous figure across the view (its MEMS mirror's two axes at
      different rates), each hit a mix of the scene's return and the other laser's (nearer than both:
      ``1 / (1/d + 1/r)``), some hits saturating to no return;
    * multipath ghost tiles: in blocks of the image (a ToF camera's processing tiles) the depth becomes a mix
      of the scene and a displaced copy of it, so the wrong values look like the room's own surfaces.

    Only pixels that move by more than 2 cm + 1% count (the truth is what changed): a ghost of a flat wall
    on itself changes nothing anyone could find."""
    rng, h, w, d = _start(frame, scale, seed, "b")
    if rng.random() < 0.5:  # Lissajous trace of another scanner's spot
        t = np.linspace(0.0, 1.0, 40_000)
        fa, fb = rng.integers(1, 9, 2)
        cx, cy = rng.uniform(0.2, 0.8) * w, rng.uniform(0.2, 0.8) * h
        ax, by = rng.uniform(0.3, 0.9) * w, rng.uniform(0.3, 0.9) * h
        px = cx + ax * np.sin(2 * np.pi * fa * t + rng.uniform(0, 2 * np.pi))
        py = cy + by * np.sin(2 * np.pi * fb * t)
        trace = np.zeros((h, w), np.uint8)
        pts = np.stack([px, py], 1).round().astype(np.int32)
        cv2.polylines(trace, [pts], False, 1, thickness=int(rng.integers(2, 10)))
        where = trace > 0
        r = rng.uniform(0.4, 3.0)
        new = 1.0 / (1.0 / np.maximum(d, 1e-3) + 1.0 / r)
        new = np.where(rng.random((h, w)) < rng.uniform(0.0, 0.5), 0.0, new)  # saturated: no return
        hit = rng.uniform(0.4, 0.95)
    else:  # multipath ghost tiles
        tile = int(rng.integers(8, 33))
        cells = rng.random((h // tile + 1, w // tile + 1)) < rng.uniform(0.1, 0.5)
        where = np.kron(cells, np.ones((tile, tile), bool))[:h, :w]
        dy, dx = (int(v) for v in rng.integers(-80, 81, 2))
        ghost = np.roll(d, (dy, dx), (0, 1))
        a = rng.uniform(0.3, 0.7)
        new = np.where(ghost > 0, (1 - a) * d + a * ghost, (1 - a) * d)
        hit = rng.uniform(0.6, 1.0)
    if rng.random() < 0.5:  # only where the views overlap: an ellipse
        ey, ex = rng.uniform(0, h), rng.uniform(0, w)
        ry, rx = rng.uniform(0.3, 0.8) * h, rng.uniform(0.3, 0.8) * w
        y, x = np.mgrid[0:h, 0:w]
        where &= ((y - ey) / ry) ** 2 + ((x - ex) / rx) ** 2 < 1
    where &= (rng.random((h, w)) < hit) & (d > 0) & (np.abs(new - d) > 0.02 + 0.01 * d)
    return _written(frame, new, where, scale)


def echo_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set C (written 2026-11-25, after sets A and B had judged eight trials, before any model ran on it: it
    judges what was chosen on them, and nothing is chosen on it): one of two more outside models, chosen by
    the seed, neither in ``d2sr.sim`` nor in sets A and B:

    * a range-gated phantom: another pulsed sensor's echo lands in this one's gate only where the scene lies
      in one shell of depth, so the hit region follows the room's surfaces (not a shape in the image); the
      hit pixels read a phantom surface at one range nearer than the shell (with jitter), or no return;
    * scan-line echo bursts: a burst of thin, nearly parallel lines (another scanner's lines, at its own
      angle), broken into segments, whose pixels read a delayed echo: too far, by a fixed offset or a factor.

    Hits are spatially clustered (a smoothed random field), and, as in set B, only pixels that move by more
    than 2 cm + 1% count."""
    rng, h, w, d = _start(frame, scale, seed, "c")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    valid = d > 0
    if rng.random() < 0.5 and valid.any():  # range-gated phantom
        qa = rng.uniform(0.0, 0.7)
        lo, hi = np.quantile(d[valid], [qa, min(qa + rng.uniform(0.15, 0.5), 1.0)])
        where = (d >= lo) & (d <= hi)
        r0 = rng.uniform(0.3, 0.9) * lo
        new = r0 + rng.normal(0.0, rng.uniform(0.01, 0.05), (h, w))
        new = np.where(rng.random((h, w)) < rng.uniform(0.0, 0.3), 0.0, np.maximum(new, 0.05))
    else:  # scan-line echo bursts
        ang = rng.uniform(-0.2, 0.2) + (np.pi / 2 if rng.random() < 0.3 else 0.0)
        across = -x * np.sin(ang) + y * np.cos(ang)  # distance across the lines
        along = x * np.cos(ang) + y * np.sin(ang)
        c0 = across[int(rng.integers(h // 10, h - h // 10)), int(rng.integers(w // 10, w - w // 10))]
        width = rng.uniform(40, 220)
        spacing, thick = rng.uniform(3, 16), rng.uniform(1, 4)
        line = (np.abs(across - c0) < width / 2) & ((across % spacing) < thick)
        seg = rng.uniform(15, 200)  # segments along each line, on or off at random
        on = rng.random(4096) < rng.uniform(0.4, 0.9)
        key = np.floor(across / spacing).astype(np.int64) * 7919 + np.floor(along / seg).astype(np.int64)
        where = line & on[key % on.size]
        new = d + rng.uniform(0.15, 1.2) if rng.random() < 0.5 else d * rng.uniform(1.15, 2.0)
        new = np.where(rng.random((h, w)) < rng.uniform(0.0, 0.2), 0.0, new)
    field = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), rng.uniform(2.0, 12.0))
    field = (field - field.mean()) / max(float(field.std()), 1e-6)
    where &= field > rng.normal(-0.5, 0.6)  # clustered partial fill
    where &= valid & (np.abs(new - d) > 0.02 + 0.01 * d)
    return _written(frame, new, where, scale)


def bloom_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set D (written 2026-11-26 and sealed until a choice made on sets A-C needed confirming, with its rule
    committed first: opened the same day for unet8-shell): one of two more outside models, chosen by the seed,
    neither in ``d2sr.sim`` nor in sets A-C:

    * emitter bloom: another sensor's emitter in view saturates a disk (no return), ringed by a halo whose
      returns read too short by a share that fades with distance, with a few rays reaching further;
    * phase-unwrapping errors: a time-of-flight camera unwraps some patches (cells of a random Voronoi
      tiling, inside a region or over the frame) one ambiguity interval off, nearer or farther by patch.

    As in sets B and C, only pixels that move by more than 2 cm + 1% count."""
    rng, h, w, d = _start(frame, scale, seed, "d")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if rng.random() < 0.5:  # emitter bloom
        cx, cy = rng.uniform(0.1, 0.9) * w, rng.uniform(0.1, 0.9) * h
        r = np.hypot(x - cx, y - cy)
        r0 = rng.uniform(5, 40)
        reach = r0 * rng.uniform(2, 6)
        theta = np.arctan2(y - cy, x - cx)
        rays = np.zeros((h, w))
        for a in rng.uniform(-np.pi, np.pi, int(rng.integers(0, 7))):
            rays = np.maximum(rays, np.exp(-((np.angle(np.exp(1j * (theta - a))) * r / 3.0) ** 2)))
        fade = np.exp(-(((r - r0) / (reach - r0)) ** 2) * (1 - 0.8 * rays))
        new = np.where(r < r0, 0.0, d * (1 - rng.uniform(0.3, 0.8) * fade))
        where = (r < r0) | (fade > 0.05)
    else:  # phase-unwrapping errors by patch
        n = int(rng.integers(8, 60))
        sites = np.stack([rng.uniform(0, h, n), rng.uniform(0, w, n)], 1)
        cell = np.argmin((y[..., None] - sites[:, 0]) ** 2 + (x[..., None] - sites[:, 1]) ** 2, axis=-1)
        wrong = rng.random(n) < rng.uniform(0.15, 0.5)
        step = np.where(rng.random(n) < 0.5, -1.0, 1.0) * rng.uniform(0.3, 1.5)
        where = wrong[cell]
        if rng.random() < 0.6:  # only where the views overlap: a half-plane
            ang = rng.uniform(0, 2 * np.pi)
            where &= x * np.cos(ang) + y * np.sin(ang) > rng.uniform(-0.3, 0.6) * max(h, w)
        new = np.maximum(d + step[cell], 0.0)
        where &= rng.random((h, w)) < rng.uniform(0.6, 1.0)
    where &= (d > 0) & (np.abs(new - d) > 0.02 + 0.01 * d)
    return _written(frame, new, where, scale)


def beat_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set E (written 2026-11-26 and sealed before any model ran on it, for choices made on sets A-D): one of
    two more outside models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-D:

    * a moire beat: two modulation frequencies beat where the views overlap, and the depth swings nearer
      and farther by a sinusoid (a grating whose period drifts across the view, at any angle) under a soft
      envelope; where the swing peaks the return saturates (no return);
    * row tearing: in a few bands of rows the readout is taken from a delayed pulse, so each band reads the
      scene shifted sideways and scaled (plausible surfaces in the wrong place), with some dropouts.

    As in sets B-D, only pixels that move by more than 2 cm + 1% count."""
    rng, h, w, d = _start(frame, scale, seed, "e")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if rng.random() < 0.5:  # moire beat
        ang = rng.uniform(0, np.pi)
        u = (x * np.cos(ang) + y * np.sin(ang)) / max(h, w)  # about 0..1.4 across the view
        period = rng.uniform(0.03, 0.2) * (1 + rng.uniform(-0.5, 0.5) * u)  # drifts across the view
        phase = 2 * np.pi * u / period + rng.uniform(0, 2 * np.pi)
        cx, cy = rng.uniform(0.1, 0.9) * w, rng.uniform(0.1, 0.9) * h
        sx, sy = rng.uniform(0.2, 0.7) * w, rng.uniform(0.2, 0.7) * h
        envelope = np.exp(-0.5 * (((x - cx) / sx) ** 2 + ((y - cy) / sy) ** 2))
        swing = rng.uniform(0.05, 0.6) * envelope * np.sin(phase)
        new = np.maximum(d + swing, 0.0)
        peak = np.abs(np.sin(phase)) * envelope > rng.uniform(0.8, 1.01)
        new = np.where(peak & (rng.random((h, w)) < 0.7), 0.0, new)
        where = envelope > 0.1
    else:  # row tearing
        where = np.zeros((h, w), bool)
        new = d.copy()
        for _ in range(int(rng.integers(1, 7))):
            top = int(rng.integers(0, h - 4))
            rows = slice(top, min(top + int(rng.integers(4, 41)), h))
            shift = int(rng.integers(10, 151)) * (1 if rng.random() < 0.5 else -1)
            band = np.roll(d[rows], shift, axis=1) * rng.uniform(0.5, 1.0)
            new[rows] = np.where(rng.random(band.shape) < rng.uniform(0.0, 0.3), 0.0, band)
            where[rows] = True
    where &= (rng.random((h, w)) < rng.uniform(0.6, 1.0)) & (d > 0) & (np.abs(new - d) > 0.02 + 0.01 * d)
    return _written(frame, new, where, scale)


def projector_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set F (written 2026-11-26 and sealed before any model ran on it, to confirm a choice made on sets A-E):
    another sensor's projector light read as this one's, one of two patterns chosen by the seed, neither in
    ``d2sr.sim`` nor in sets A-E:

    * a dot lattice: a structured-light sensor's dots (a slanted hexagonal grid, 1-3 pixels each, jittered)
      over a patch of the view, each dot reading too near (the two lights mixed) or no return;
    * Gray-code stripes: a coded-light projector's lit stripes (one bit plane of a Gray code: stripes of
      varying width, at any angle) read nearer or farther (by frame) by an offset that grows with range,
      and sometimes no return at their edges.

    As in sets B-E, only pixels that move by more than 2 cm + 1% count."""
    rng, h, w, d = _start(frame, scale, seed, "f")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if rng.random() < 0.5:  # dot lattice
        pitch, ang = rng.uniform(5, 16), rng.uniform(0, np.pi / 3)
        u = (x * np.cos(ang) + y * np.sin(ang)) / pitch
        v = (-x * np.sin(ang) + y * np.cos(ang)) / (pitch * np.sqrt(3) / 2)
        row = np.floor(v + 0.5)
        du = u - np.floor(u + 0.5 * (row % 2)) - 0.5 * (row % 2)  # hexagonal: odd rows shifted half a pitch
        du = np.where(du > 0.5, du - 1, np.where(du < -0.5, du + 1, du))
        dist = np.hypot(du * pitch, (v - row) * pitch * np.sqrt(3) / 2)
        where = dist < rng.uniform(1.0, 3.0) + rng.normal(0, 0.3, (h, w))
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        where &= np.hypot((x - cx) / w, (y - cy) / h) < rng.uniform(0.3, 0.9)  # a patch of the view
        r = rng.uniform(0.3, 2.0)
        new = 1.0 / (1.0 / np.maximum(d, 1e-3) + 1.0 / r)
        new = np.where(rng.random((h, w)) < rng.uniform(0.0, 0.4), 0.0, new)
    else:  # Gray-code stripes
        ang = rng.uniform(0, np.pi)
        s = x * np.cos(ang) + y * np.sin(ang)
        s = (s - s.min()) / max(float(np.ptp(s)), 1.0)
        code = np.floor(s * 2 ** int(rng.integers(3, 8))).astype(np.int64)
        bit = int(rng.integers(0, 3))
        stripe = ((code ^ (code >> 1)) >> bit) & 1  # one bit plane of the Gray code
        offset = rng.uniform(0.04, 0.25) * (1 + rng.uniform(0.0, 0.5) * d)
        new = np.maximum(d + offset * (-1 if rng.random() < 0.5 else 1), 0.05)
        edge = cv2.morphologyEx(stripe.astype(np.uint8), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
        new = np.where(edge & (rng.random((h, w)) < rng.uniform(0.0, 0.8)), 0.0, new)
        where = stripe == 1
        if rng.random() < 0.6:  # only where the views overlap: a half-plane
            a2 = rng.uniform(0, 2 * np.pi)
            where &= x * np.cos(a2) + y * np.sin(a2) > rng.uniform(-0.3, 0.6) * max(h, w)
    where &= (rng.random((h, w)) < rng.uniform(0.6, 1.0)) & (d > 0) & (np.abs(new - d) > 0.02 + 0.01 * d)
    return _written(frame, new, where, scale)


def tof_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set G (written and sealed 2026-11-26, before any model or scene reference ran on it, for issue 42's
    scene evidence): another continuous-wave time-of-flight camera's modulated light added to this one's.
    Its phasor pulls the measured phase, so a surface it lights reads shifted by a few centimetres, smoothly
    and coherently, with almost no dropouts: a plausible surface in the wrong place. One of two models,
    chosen by the seed, neither in ``d2sr.sim`` nor in sets A-F:

    * a lit patch: the other camera's illumination cone (a soft-edged ellipse) with an irradiance that falls
      off with range; the shift, 2-5 cm at its peak, follows the phasor's pull (amplitude ratio times the
      sine of a relative phase that turns slowly across the view), nearer on three frames in four;
    * a lit surface: the surfaces within one shell of range (a wall, the floor), shifted by 2-5 cm with a
      long ripple, over a half-plane of the view where the views overlap; where the two phasors nearly
      cancel, a few pixels return nothing (at most 1%).

    Pixels that move by more than 1 cm count (the shifts are the point: sets B-F's 2 cm + 1% would drop
    most of them beyond 3 m). A draw that moves under 1% of the returns (a thin object's shell, a cone on
    a near one) is drawn again, so that no corrupted frame is left all but unchanged."""
    rng, _, _, d = _start(frame, scale, seed, "g")
    patch = rng.random() < 0.5  # the first draw picks the model (``kind``)
    for _ in range(20):
        where, new = _tof_draw(rng, d, patch)
        if where.sum() >= 0.01 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def _tof_draw(rng: np.random.Generator, d: np.ndarray, patch: bool) -> tuple[np.ndarray, np.ndarray]:
    """One draw of set G's models: the pixels that move and the depth they read."""
    h, w = d.shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    sign = -1.0 if rng.random() < 0.75 else 1.0
    peak = rng.uniform(0.02, 0.05)
    ys, xs = np.nonzero(d > 0)
    at = int(rng.integers(0, max(len(ys), 1)))
    px, py = (float(xs[at]), float(ys[at])) if len(ys) else (w / 2, h / 2)  # a returning pixel it lights
    if patch:  # a lit patch
        sx, sy, rot = rng.uniform(0.12, 0.45) * w, rng.uniform(0.12, 0.45) * h, rng.uniform(0, np.pi)
        u = ((x - px) * np.cos(rot) + (y - py) * np.sin(rot)) / sx
        v = (-(x - px) * np.sin(rot) + (y - py) * np.cos(rot)) / sy
        cone = np.clip((1.2 - np.hypot(u, v)) / 0.4, 0.0, 1.0) * (d > 0)  # soft edge; returns only
        ratio = cone / np.maximum(d, 0.3) ** 2  # irradiance falls off with range
        ang, k = rng.uniform(0, 2 * np.pi), rng.uniform(0.5, 2.0) * np.pi / max(h, w)
        turn = np.sin(k * (x * np.cos(ang) + y * np.sin(ang)) + rng.uniform(0, 2 * np.pi))
        pull = ratio * (0.6 + 0.4 * turn)
        new = d + sign * peak * pull / max(float(pull.max()), 1e-9)
        where = cone > 0
    else:  # a lit surface
        lo = float(d[int(py), int(px)]) - rng.uniform(0.0, 0.3)
        shell = (d >= lo) & (d < lo + rng.uniform(0.3, 1.5))
        ang, k = rng.uniform(0, 2 * np.pi), rng.uniform(0.3, 1.5) * np.pi / max(h, w)
        ripple = 0.75 + 0.25 * np.sin(k * (x * np.cos(ang) + y * np.sin(ang)) + rng.uniform(0, 2 * np.pi))
        new = d + sign * peak * ripple
        a2 = rng.uniform(0, 2 * np.pi)  # where the views overlap: a half-plane with that pixel inside
        side = (x - px) * np.cos(a2) + (y - py) * np.sin(a2)
        where = shell & (side > -rng.uniform(0.1, 0.6) * max(h, w))
        new = np.where(rng.random((h, w)) < rng.uniform(0.0, 0.01), 0.0, new)
    return where & (d > 0) & (np.abs(new - d) > 0.01), new


def tof_bias_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set H (written and sealed 2026-11-26, before any model or scene reference ran on it, to judge the
    scene's shifted windows, which were tuned on set G after it was opened): two more ways a CW-ToF
    camera's depth is biased by a few centimetres with no dropouts, neither in ``d2sr.sim`` nor in sets
    A-G. One of two models, chosen by the seed:

    * multipath: light that reaches a surface by way of a brighter neighbouring one makes it read farther.
      The bias, 1.5-4 cm at its peak, is highest beside the scene's range edges (where one surface sees
      another) and fades over 20-60 px, over some of those edges only;
    * phase crosstalk: another camera's modulation beating with this one's, a sinusoid across the view
      (period 40-160 px, amplitude 1.5-3.5 cm, both ways), over a band of the view where the two overlap.

    Pixels that move by more than 1 cm count, as in set G. A draw that moves under 1% of the returns is
    drawn again."""
    rng, _, _, d = _start(frame, scale, seed, "h")
    multipath = rng.random() < 0.5  # the first draw picks the model (``kind``)
    for _ in range(20):
        new = _bias_draw(rng, d, multipath)
        where = (d > 0) & (np.abs(new - d) > 0.01)
        if where.sum() >= 0.01 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def _bias_draw(rng: np.random.Generator, d: np.ndarray, multipath: bool) -> np.ndarray:
    """One draw of set H's models: the depth (metres) every pixel reads."""
    h, w = d.shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if multipath:
        filled = cv2.dilate(d.astype(np.float32), np.ones((5, 5), np.uint8))  # bridge lone dropouts
        gy, gx = np.gradient(filled)
        edges = ((np.hypot(gx, gy) > 0.05) & (d > 0)).astype(np.float32)
        keep = cv2.resize(rng.random((4, 4)).astype(np.float32), (w, h), interpolation=cv2.INTER_NEAREST)
        edges *= keep < rng.uniform(0.3, 0.8)  # some of the edges: where a bright surface faces another
        sigma = rng.uniform(20, 60)
        field = cv2.GaussianBlur(edges, (0, 0), sigma)
        field = field / max(float(field.max()), 1e-9)
        return d + rng.uniform(0.015, 0.04) * np.clip(1.6 * field, 0, 1)
    ang, period = rng.uniform(0, np.pi), rng.uniform(40, 160)
    s = x * np.cos(ang) + y * np.sin(ang)
    wave = rng.uniform(0.015, 0.035) * np.sin(2 * np.pi * s / period + rng.uniform(0, 2 * np.pi))
    a2 = rng.uniform(0, 2 * np.pi)  # the band where the views overlap
    t = x * np.cos(a2) + y * np.sin(a2)
    t = (t - t.min()) / max(float(t.max() - t.min()), 1e-9)
    lo = rng.uniform(0.0, 0.5)
    band = (t >= lo) & (t <= lo + rng.uniform(0.3, 0.7))
    return np.where(band, d + wave, d)


def sparse_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set I (written and sealed 2026-11-26, before the guard's lone-return rule, chosen on sets A-H, ran on
    it): interference that leaves lone wrong returns among dropouts, the case that rule gives up. One of
    two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-H:

    * blackout sparkle: another sensor's light floods a region (an ellipse, 10-40% of the view) and blinds
      this one: 85-98% of its returns drop out, and 30-70% of the few that survive read too near (30-85%
      of their depth);
    * scan ghost: another scanner's beam sweeps a column band (20-120 px wide) and this sensor reads its
      direct light at scattered pixels (2-10% of the band, returns and dropouts alike) at the other
      sensor's range (0.4-1.5 m, +-5 cm), while 50-90% of its own returns there drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.5% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "i")
    blackout = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w]
    for _ in range(20):
        if blackout:
            region = _ellipse(rng, y, x, 0.10, 0.40) < 1
            drop = region & (rng.random((h, w)) < rng.uniform(0.85, 0.98))
            near = region & ~drop & (rng.random((h, w)) < rng.uniform(0.3, 0.7))
            new = np.where(drop, 0.0, np.where(near, d * rng.uniform(0.3, 0.85, (h, w)), d))
        else:
            x0 = rng.uniform(0, w)
            band = np.abs(x - x0) < rng.uniform(10, 60)
            r = rng.uniform(0.4, 1.5)
            ghost = band & (rng.random((h, w)) < rng.uniform(0.02, 0.10))
            drop = band & ~ghost & (rng.random((h, w)) < rng.uniform(0.5, 0.9))
            new = np.where(ghost, r + rng.uniform(-0.05, 0.05, (h, w)), np.where(drop, 0.0, d))
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)
