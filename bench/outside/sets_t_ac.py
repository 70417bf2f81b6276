"""Sets T-AC, each written and sealed to judge one setting of the scene (``bench.outside.sets.STATUS``)."""

from __future__ import annotations

import cv2
import numpy as np
from bench.outside.draw import _ellipse, _start, _written


def stair_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set T (written and sealed 2026-11-27, before a recording's loop judged its first frames against a
    scene learned from the frames ahead, to judge that: decisions.md). Another sensor's light saturating this
    one's receiver over part of the view, so that its timing reads coarse. One of two models, chosen by the
    seed, neither in ``d2sr.sim`` nor in sets A-S:

    * range staircase: in 1-2 ellipses (each 6-25% of the view), every return snaps to a grid of steps 4-12 cm
      apart (at a random phase), and 0-10% of them drop out;
    * clamped plane: in a convex polygon of 4-7 corners (5-25% of the view), every return reads one depth,
      the region's 10th-40th percentile, with 0.5-1.5 cm of noise: a flat wall where the scene has shape.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "t")
    stairs = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if stairs:
            region = np.zeros((h, w), bool)
            for _ in range(int(rng.integers(1, 3))):
                region |= _ellipse(rng, y, x, 0.06, 0.25) < 1
            step = rng.uniform(0.04, 0.12)
            phase = rng.uniform(0, step)
            new = np.where(region & has, np.round((d - phase) / step) * step + phase, d)
            new = np.where(region & has & (rng.random((h, w)) < rng.uniform(0, 0.1)), 0.0, new)
        else:
            k = int(rng.integers(4, 8))
            cy, cx = rng.uniform(0.2, 0.8) * h, rng.uniform(0.2, 0.8) * w
            radius = np.sqrt(rng.uniform(0.05, 0.25) * h * w / np.pi)
            ang = np.sort(rng.uniform(0, 2 * np.pi, k))
            r = radius * rng.uniform(0.7, 1.3, k)
            corners = np.stack([cx + r * np.cos(ang), cy + r * np.sin(ang)], 1)
            region = np.zeros((h, w), np.uint8)
            cv2.fillConvexPoly(region, cv2.convexHull(np.rint(corners).astype(np.int32)), 1)
            inside = region.astype(bool) & has
            level = float(np.percentile(d[inside], rng.uniform(10, 40))) if inside.any() else 0.0
            noise = rng.normal(0, rng.uniform(0.005, 0.015), (h, w))
            new = np.where(inside, np.maximum(level + noise, 0.05), d)
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def cwtof_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set U (written and sealed 2026-11-27, before a subtle shift was explained by the frame before only
    within ``SHIFT_M`` of its depth, to judge that: decisions.md). Another continuous-wave time-of-flight
    camera's light mixing into this one's phase over part of the view: coherent surfaces read a few
    centimetres off, with no dropouts. One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in
    sets A-T:

    * phase beat: in an ellipse (5-25% of the view), every return reads nearer by an offset that beats
      across it between 2 cm and 2-5 cm (a sinusoid 40-160 px long at a random angle);
    * readout bands: 2-5 bands of rows (8-40 rows each) across 40-100% of the width, where every return
      reads one band's offset off: 2-4 cm, nearer in 4 bands of 5, farther in the rest.

    Every return in the region changes; a draw that changes under 0.5% of the returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "u")
    beat = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if beat:
            region = _ellipse(rng, y, x, 0.05, 0.25) < 1
            ang = rng.uniform(0, np.pi)
            wave = np.sin(
                2 * np.pi * (x * np.cos(ang) + y * np.sin(ang)) / rng.uniform(40, 160) + rng.uniform(0, 6.3)
            )
            top = rng.uniform(0.02, 0.05)
            offset = np.where(region, 0.02 + (top - 0.02) * (wave + 1) / 2, 0.0)
        else:
            offset = np.zeros((h, w))
            x0 = rng.uniform(0, 0.6) * w
            x1 = x0 + rng.uniform(0.4, 1.0) * w
            for _ in range(int(rng.integers(2, 6))):
                r0 = int(rng.integers(0, h))
                rows = slice(r0, r0 + int(rng.integers(8, 41)))
                off = rng.uniform(0.02, 0.04) * (1 if rng.random() < 0.8 else -1)
                band = np.zeros((h, w), bool)
                band[rows] = True
                offset = np.where(band & (x >= x0) & (x < x1), off, offset)
        where = has & (offset != 0)
        new = np.where(where, np.maximum(d - offset, 0.05), d)
        if where.sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def halo_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set V (written and sealed 2026-11-27, before shifted windows were worked out over pixels that return
    in 70% of the clean frames instead of 90%, to judge that: decisions.md). Another time-of-flight camera's
    light read as a few centimetres of range over part of the view, with no dropouts. One of two models,
    chosen by the seed, neither in ``d2sr.sim`` nor in sets A-U:

    * halo ring: an annulus (inner radius 20-90 px, 10-40 px wide, of random aspect) around a random point of
      the view's middle, where every return reads 2-4 cm farther (one offset per frame);
    * offset cells: an ellipse (10-30% of the view) cut into square cells 8-24 px wide, 40-70% of which read
      2-4 cm off (each cell its own offset and sign).

    Every return in the affected pixels changes; a draw that changes under 0.5% of the returns is drawn
    again."""
    rng, h, w, d = _start(frame, scale, seed, "v")
    ring = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if ring:
            cy, cx = rng.uniform(0.25, 0.75) * h, rng.uniform(0.25, 0.75) * w
            aspect = rng.uniform(0.7, 1.4)
            r = np.hypot(x - cx, (y - cy) * aspect)
            inner = rng.uniform(20, 90)
            offset = np.where((r >= inner) & (r < inner + rng.uniform(10, 40)), -rng.uniform(0.02, 0.04), 0.0)
        else:
            region = _ellipse(rng, y, x, 0.10, 0.30) < 1
            cell = int(rng.integers(8, 25))
            rows, cols = -(-h // cell), -(-w // cell)
            pick = rng.random((rows, cols)) < rng.uniform(0.4, 0.7)
            size = rng.uniform(0.02, 0.04, (rows, cols)) * np.where(rng.random((rows, cols)) < 0.5, 1, -1)
            per = np.where(pick, size, 0.0)
            offset = np.where(region, np.kron(per, np.ones((cell, cell)))[:h, :w], 0.0)
        where = has & (offset != 0)
        new = np.where(where, np.maximum(d - offset, 0.05), d)
        if where.sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def flare_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set W (written and sealed 2026-11-27, before shifted windows waited for a full ring of clean frames to
    count pixels returning 70% of the time, to judge that: decisions.md). Another sensor's light glaring or
    echoing off the scene. One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-V:

    * flare streak: 1-3 long thin ellipses (100-400 px long, 6-20 px wide, at random angles) where 40-80% of
      the returns read 10-60% nearer and a tenth of those drop out;
    * echo shadow: the scene's nearer surfaces echoed 10-40 px sideways: where the pixel that far to one side
      reads over 20 cm nearer, 50-90% of the returns read its depth instead.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "w")
    flare = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if flare:
            hit = np.zeros((h, w), bool)
            for _ in range(int(rng.integers(1, 4))):
                ang = rng.uniform(0, np.pi)
                cy, cx = rng.uniform(0.1, 0.9) * h, rng.uniform(0.1, 0.9) * w
                u = (x - cx) * np.cos(ang) + (y - cy) * np.sin(ang)
                v = -(x - cx) * np.sin(ang) + (y - cy) * np.cos(ang)
                hit |= (u / (rng.uniform(100, 400) / 2)) ** 2 + (v / (rng.uniform(6, 20) / 2)) ** 2 < 1
            hit &= has & (rng.random((h, w)) < rng.uniform(0.4, 0.8))
            new = np.where(hit, d * (1 - rng.uniform(0.1, 0.6, (h, w))), d)
            new = np.where(hit & (rng.random((h, w)) < 0.1), 0.0, new)
        else:
            shift = int(rng.integers(10, 41)) * (1 if rng.random() < 0.5 else -1)
            echo = np.roll(d, shift, axis=1)
            hit = has & (echo > 0) & (echo < d - 0.2) & (rng.random((h, w)) < rng.uniform(0.5, 0.9))
            new = np.where(hit, echo, d)
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def block_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set X (written and sealed 2026-11-27, before a recording's primed scene was kept only where the sensor
    held still over the frames ahead, to judge that: decisions.md). One of two models, chosen by the seed,
    neither in ``d2sr.sim`` nor in sets A-W:

    * block crosstalk: 200-1500 blocks of 3x3 pixels inside an ellipse (10-40% of the view), each read 5-30 cm
      off (nearer or farther) as a whole;
    * ring dropout: thin rings (2-4 px wide, 12-40 px apart) around a point of the view, on which 50-90% of
      the returns drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "x")
    blocks = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if blocks:
            region = _ellipse(rng, y, x, 0.10, 0.40) < 1
            ys, xs = np.nonzero(region[1:-1, 1:-1])
            pick = rng.choice(len(ys), size=min(int(rng.integers(200, 1501)), len(ys)), replace=False)
            offset = np.zeros((h, w))
            for cy, cx in zip(ys[pick] + 1, xs[pick] + 1, strict=True):
                offset[cy - 1 : cy + 2, cx - 1 : cx + 2] = rng.uniform(0.05, 0.3) * (
                    1 if rng.random() < 0.5 else -1
                )
            new = np.where(has & (offset != 0), np.maximum(d + offset, 0.05), d)
        else:
            cy, cx = rng.uniform(0.2, 0.8) * h, rng.uniform(0.2, 0.8) * w
            r = np.hypot(x - cx, y - cy)
            ring = (r % rng.uniform(12, 40)) < rng.uniform(2, 4)
            drop = ring & has & (rng.random((h, w)) < rng.uniform(0.5, 0.9))
            new = np.where(drop, 0.0, d)
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def haze_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set Y (written and sealed 2026-11-27, before a detector's flag on a frame the scene finds quiet was
    kept where the scene cannot vouch for what the detector saw, to judge that: decisions.md). Another
    sensor's light where this one's own returns are weak. One of two models, chosen by the seed, neither in
    ``d2sr.sim``; far haze is in no set A-X, edge bleed is close to set O's flying edges (noticed after Y was
    opened), with a wider window and more dropouts:

    * far haze: inside an ellipse (20-50% of the view), the returns beyond the 40th-70th percentile of its
      depths (the far, weak ones) are hit: 40-80% of them drop out, and 20-50% of those far pixels, with a
      return or without, read the other sensor's backscatter instead, a depth that ramps across the view
      between two values of 0.4-1.5 m (+-2%);
    * edge bleed: around the range edges (a 9x9 window whose returns span over 30 cm) inside an ellipse
      (20-60% of the view), widened by 2-5 px, 30-70% of the returns read a depth between the window's
      nearest and farthest and 20-40% drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.3% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "y")
    haze = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    k9 = np.ones((9, 9), np.uint8)
    near = cv2.erode(np.where(has, d, np.inf).astype(np.float32), k9).astype(np.float64)
    far = cv2.dilate(d.astype(np.float32), k9).astype(np.float64)
    for _ in range(20):
        if haze:
            region = _ellipse(rng, y, x, 0.20, 0.50) < 1
            inside = d[region & has]
            cut = np.percentile(inside, rng.uniform(40, 70)) if inside.size else np.inf
            weak = region & (has & (d > cut) | ~has)
            drop = weak & has & (rng.random((h, w)) < rng.uniform(0.4, 0.8))
            ang = rng.uniform(0, 2 * np.pi)
            s = ((x - w / 2) * np.cos(ang) + (y - h / 2) * np.sin(ang)) / np.hypot(h, w) + 0.5
            a, b = rng.uniform(0.4, 1.5, 2)
            back = (a + (b - a) * s) * (1 + rng.uniform(-0.02, 0.02, (h, w)))
            ghost = weak & (rng.random((h, w)) < rng.uniform(0.2, 0.5))
            new = np.where(ghost, back, np.where(drop, 0.0, d))
        else:
            region = _ellipse(rng, y, x, 0.20, 0.60) < 1
            edge = (far - np.where(np.isfinite(near), near, far) > 0.3) & region
            grow = int(rng.integers(2, 6))
            edge = cv2.dilate(edge.astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0
            mixed = edge & has & np.isfinite(near) & (rng.random((h, w)) < rng.uniform(0.3, 0.7))
            alpha = rng.uniform(0.2, 0.8, (h, w))
            drop = edge & has & ~mixed & (rng.random((h, w)) < rng.uniform(0.2, 0.4))
            blend = alpha * np.where(np.isfinite(near), near, 0) + (1 - alpha) * far
            new = np.where(mixed, blend, np.where(drop, 0.0, d))
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.003 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def ripple_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set Z (written and sealed 2026-11-27, before off windows flagged frames, to judge that: decisions.md).
    Another sensor's light that reads a surface a few centimetres off both ways at once, so that its mean over
    a patch stays about right. One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-Y:

    * row interleave: inside an ellipse (10-35% of the view), the returns of alternate runs of 1-2 rows read
      2-5 cm nearer and the others as far farther (a line-interleaved phase error);
    * ripple: concentric rings around a point of the view's middle three fifths, out to 40-150 px: every
      return reads off by a sinusoid of the distance to it, 2-5 cm at its crests, 6-16 px from crest to crest.

    Pixels that change by more than 2 cm count, with their dropouts (none here); a draw that changes under
    0.3% of the returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "z")
    rows = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if rows:
            region = _ellipse(rng, y, x, 0.10, 0.35) < 1
            run = int(rng.integers(1, 3))
            sign = np.where((y.astype(int) // run) % 2 == 0, -1.0, 1.0)
            new = np.where(region & has, d + sign * rng.uniform(0.02, 0.05), d)
        else:
            cy, cx = rng.uniform(0.2, 0.8) * h, rng.uniform(0.2, 0.8) * w
            r = np.hypot(x - cx, y - cy)
            crest, length, phase = rng.uniform(0.02, 0.05), rng.uniform(6, 16), rng.uniform(0, 2 * np.pi)
            wave = crest * np.sin(2 * np.pi * r / length + phase)
            new = np.where(has & (r < rng.uniform(40, 150)), d + wave, d)
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.003 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def echo_grain_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set AA (written and sealed 2026-11-27, before the scene's repair took its depth for every fresh far-off
    return of a frame they flag, to judge that: decisions.md). One of two models, chosen by the seed, neither
    in ``d2sr.sim`` nor in sets A-Z:

    * late echoes: inside an ellipse (10-40% of the view), grains of 2-6 px (5-25% of its returns) read
      another pulse's later echo: their own depth plus 0.2-1.5 m (one draw per grain, +-1%), farther than the
      surface, where every set before reads too near or blends; 0-10% of the ellipse's returns drop out;
    * pile-up band: the returns between two percentiles of the view's depths (a band of 20-40% of them,
      starting at the 0th-30th percentile: the nearest, strongest) read 3-15% too near (a pulsed sensor's
      walk error when another's light piles up on strong returns), with 1% of noise, and 5-20% of them drop
      out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.3% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "aa")
    echoes = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if echoes:
            region = _ellipse(rng, y, x, 0.10, 0.40) < 1
            grain = int(rng.integers(2, 7))
            gh, gw = -(-h // grain), -(-w // grain)
            cells = rng.random((gh, gw)) < rng.uniform(0.05, 0.25)
            late = rng.uniform(0.2, 1.5, (gh, gw))
            up = np.ones((grain, grain))
            hit = np.kron(cells, up)[:h, :w] > 0
            extra = np.kron(late, up)[:h, :w] * (1 + rng.uniform(-0.01, 0.01, (h, w)))
            drop = region & has & (rng.random((h, w)) < rng.uniform(0.0, 0.10))
            new = np.where(region & has & hit, d + extra, np.where(drop, 0.0, d))
        else:
            valid = d[has]
            start = rng.uniform(0, 30)
            lo, hi = np.percentile(valid, [start, start + rng.uniform(20, 40)]) if valid.size else (0.0, 0.0)
            band = has & (d >= lo) & (d <= hi)
            near = d * (1 - rng.uniform(0.03, 0.15)) * (1 + rng.normal(0, 0.01, (h, w)))
            drop = band & (rng.random((h, w)) < rng.uniform(0.05, 0.20))
            new = np.where(drop, 0.0, np.where(band, near, d))
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.003 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def fold_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set AB (written and sealed 2026-11-27, before the scene's repair took its depth for far-off returns in
    patches where it seldom returns, to judge that: decisions.md). One of two models, chosen by the seed,
    neither in ``d2sr.sim`` nor in sets A-AA:

    * range folding: another pulsed sensor's pulse train sets an unambiguous range R (the 50th-90th
      percentile of the view's depths); inside an ellipse (20-50% of the view), 30-80% of the returns beyond
      R read d - R (+-1%), the rest of them there drop out with a chance of 0-30%;
    * pulse curtains: 1-3 vertical bands, each 5-40 px wide, where the other sensor's pulses arrive at a
      fixed delay: 20-60% of the band's pixels, with a return or without, read one depth of 0.5-3 m (+-1%),
      and 5-15% of its returns drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.3% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "ab")
    folding = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        if folding:
            region = _ellipse(rng, y, x, 0.20, 0.50) < 1
            valid = d[has]
            far_range = np.percentile(valid, rng.uniform(50, 90)) if valid.size else np.inf
            beyond = region & has & (d > far_range)
            folded = beyond & (rng.random((h, w)) < rng.uniform(0.3, 0.8))
            drop = beyond & ~folded & (rng.random((h, w)) < rng.uniform(0.0, 0.3))
            near = (d - far_range) * (1 + rng.uniform(-0.01, 0.01, (h, w)))
            new = np.where(folded, near, np.where(drop, 0.0, d))
        else:
            band = np.zeros((h, w), bool)
            for _b in range(int(rng.integers(1, 4))):
                width = int(rng.integers(5, 41))
                x0 = int(rng.integers(0, max(w - width, 1)))
                band[:, x0 : x0 + width] = True
            depth = rng.uniform(0.5, 3.0)
            hit = band & (rng.random((h, w)) < rng.uniform(0.2, 0.6))
            drop = band & has & ~hit & (rng.random((h, w)) < rng.uniform(0.05, 0.15))
            new = np.where(hit, depth * (1 + rng.uniform(-0.01, 0.01, (h, w))), np.where(drop, 0.0, d))
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.003 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def shifted_surface_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set AC (written and sealed 2026-11-27, before the scene's repair gave a shifted surface's returns their
    own depth less their window's offset, to judge that: decisions.md). Two more ways another
    continuous-wave time-of-flight camera reads whole surfaces a few centimetres off, with no dropouts, one
    chosen by the seed, neither in ``d2sr.sim`` nor in sets A-AB:

    * bright object: the other camera's light comes back strongest from one object, grown from a returning
      pixel over neighbours whose depth steps by under 2% (within an ellipse of 15-45% of the view): it
      reads 2-5 cm off (nearer on three frames in four), tilted across it by up to a third of that, with
      2-6 mm of extra noise;
    * wiggle bands: where the views overlap (a half-plane of the view with a returning pixel inside, its
      edge softened over 10-40 px), the two modulations beat into a cyclic error that follows range: every
      return reads off by 2-5 cm times the sine of its depth over a period of 0.5-1.5 m, so the bands
      follow the scene's iso-depth lines.

    Pixels that move by more than 5 mm count (the sensor's own noise at a few metres); a draw that moves
    under 1% of the returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "ac")
    bright = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    new, where = d, np.zeros((h, w), bool)
    for _ in range(20):
        region = _ellipse(rng, y, x, 0.15, 0.45) < 1 if bright else np.ones((h, w), bool)
        ys, xs = np.nonzero(has & region)
        at = int(rng.integers(0, max(len(ys), 1)))
        px, py = (int(xs[at]), int(ys[at])) if len(ys) else (w // 2, h // 2)
        size = rng.uniform(0.02, 0.05) * (-1.0 if rng.random() < 0.75 else 1.0)
        if bright:
            grown = np.zeros((h + 2, w + 2), np.uint8)
            step = float(0.02 * max(d[py, px], 0.1))
            depth = np.where(has & region, d, 0.0).astype(np.float32)
            flags = 4 | cv2.FLOODFILL_MASK_ONLY | (1 << 8)
            cv2.floodFill(depth, grown, (px, py), 0, step, step, flags)
            obj = (grown[1:-1, 1:-1] > 0) & has & region
            ang = rng.uniform(0, 2 * np.pi)
            across = (x - px) * np.cos(ang) + (y - py) * np.sin(ang)
            span = max(float(np.abs(across[obj]).max()) if obj.any() else 1.0, 1.0)
            tilt = 1 + rng.uniform(-1 / 3, 1 / 3) * across / span
            noise = rng.normal(0, rng.uniform(0.002, 0.006), (h, w))
            new = np.where(obj, d + size * tilt + noise, d)
        else:
            a2 = rng.uniform(0, 2 * np.pi)
            side = (x - px) * np.cos(a2) + (y - py) * np.sin(a2) + rng.uniform(0.1, 0.6) * max(h, w)
            weight = np.clip(side / rng.uniform(10, 40), 0.0, 1.0)
            period = rng.uniform(0.5, 1.5)
            cyclic = np.sin(2 * np.pi * d / period + rng.uniform(0, 2 * np.pi))
            new = np.where(has, d + size * weight * cyclic, d)
        where = has & (np.abs(new - d) > 0.005)
        if where.sum() >= 0.01 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)
